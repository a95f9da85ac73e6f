/* `tradeoff`: the speed/accuracy trade measured on the user's own scene and camera. Every
 * method runs over a quality ladder (bake, then a baked render of the view); each picture is
 * compared with a Monte-Carlo reference of the same view that is rendered once, to a noise
 * target, and cached in the output folder under a key of the resolved scene, so that a rerun
 * reuses it. The reference's own error against time (fewer samples per pixel) is measured
 * beside it, so the table answers "is a bake worth it here at all". Writes tradeoff.csv,
 * tradeoff.md and tradeoff.png (docs/tradeoff.md). */
#ifndef VDBSCATTER_TRADEOFF_H
#define VDBSCATTER_TRADEOFF_H

#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/cancel.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VDBS_TRADEOFF_MAX_METHODS 8
#define VDBS_TRADEOFF_MAX_CURVE 16

/* The image size when the caller gives none. */
#define VDBS_TRADEOFF_WIDTH 128
#define VDBS_TRADEOFF_HEIGHT 96

/* Zero-initialise; 0 means "choose the default". */
typedef struct vdbs_tradeoff_desc {
    const char *input;       /* density VDB; scene->volume_file when NULL */
    const vdbs_scene *scene; /* validated, with lights; its method and quality are ignored */
    const char *dir;         /* output folder (created; the reference cache lives there) */
    /* Method names (solver.h); 0: every solver in table order. */
    const char *methods[VDBS_TRADEOFF_MAX_METHODS];
    int method_count;
    /* The quality steps to run: bit L for level L (quality.h: 0 low .. 3 ultra); 0: low,
     * medium and high. */
    unsigned qualities;
    const vdbs_camera *camera; /* NULL: the scene's camera, else a view of the whole volume */
    int width, height;         /* 0: VDBS_TRADEOFF_WIDTH x VDBS_TRADEOFF_HEIGHT */
    /* The reference: rendered to this relative standard error of the image,
     * sqrt(mean se^2) / sqrt(mean L^2) (0: 0.01), in at most ref_seconds (0: 600). */
    double ref_noise;
    double ref_seconds;
    uint64_t seed; /* the reference's (0 is a seed like any other) */
    vdbs_backend backend;
    int progress; /* one line per step on stderr */
    vdbs_warn_fn warn;
    void *warn_user;
    const vdbs_cancel *cancel; /* polled through every bake and render; NULL: never */
    int64_t max_memory;        /* every bake's and render's (vdbs_bake_options.max_memory) */
} vdbs_tradeoff_desc;

/* One method at one quality. */
typedef struct vdbs_tradeoff_row {
    char method[32];
    char quality[16];
    double seconds_bake, seconds_render; /* each command's whole time, files included */
    double peak_mib;                     /* the process's peak resident memory over the
                                            bake and render (Linux; -1 where unknown) */
    double relrmse;    /* image relative RMSE against the reference, its noise removed */
    double relrmse_se; /* that estimate's standard error from the reference's se */
    double mean_ratio; /* sum(method) / sum(reference) */
    int pareto;        /* 1: no cheaper row has an error as low */
} vdbs_tradeoff_row;

/* The reference at fewer samples per pixel (other seeds) against the cached reference. */
typedef struct vdbs_tradeoff_curve_point {
    int spp;
    double seconds;
    double relrmse; /* its noise: relative RMSE against the reference, the reference's
                       own noise removed */
} vdbs_tradeoff_curve_point;

typedef struct vdbs_tradeoff_report {
    vdbs_tradeoff_row *rows; /* methods x qualities, in that order */
    int row_count;
    char key[17];         /* the reference's cache key (hex) */
    int reference_cached; /* 1: read from the cache, not rendered */
    int reference_spp;
    double reference_seconds; /* what rendering it took (then, when cached) */
    double reference_noise;   /* its relative standard error, as defined above */
    vdbs_tradeoff_curve_point curve[VDBS_TRADEOFF_MAX_CURVE];
    int curve_count;
    int width, height;
    char csv[VDBS_PATH_MAX], markdown[VDBS_PATH_MAX], plot[VDBS_PATH_MAX];
    double seconds_total;
} vdbs_tradeoff_report;

/* Runs the whole measurement and writes the files. Errors: the bake's and render's input
 * errors (VDBS_ERR_INPUT, one line), an unknown method, a folder that cannot be made. */
vdbs_status vdbs_tradeoff_run(const vdbs_tradeoff_desc *desc, vdbs_tradeoff_report *report,
                              vdbs_error *err);
void vdbs_tradeoff_report_free(vdbs_tradeoff_report *report);

/* Image a against a noisy reference b with per-pixel standard errors b_se (NULL: exact). */
typedef struct vdbs_tradeoff_metrics {
    /* Relative RMSE with the reference's noise removed from the mean square error:
     * mse = mean((a-b)^2) - mean(b_se^2) (at least 0) */
    double relrmse;
    /* that estimate's standard error, its variance from the cross term 4 (a-b)^2 se^2 and
     * the noise's own 2 se^4 */
    double relrmse_se;
    double mean_ratio; /* sum(a) / sum(b); 0 when sum(b) is not positive */
} vdbs_tradeoff_metrics;

/* The metrics of n values each, in one pass. */
void vdbs_tradeoff_measure(const float *a, const float *b, const float *b_se, long long n,
                           vdbs_tradeoff_metrics *metrics);

#ifdef __cplusplus
}
#endif

#endif
