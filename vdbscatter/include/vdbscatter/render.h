/* Pictures of a volume: `vdbs_render()` is the whole `render` job (open the input, merge a
 * lit VDB's scene with the caller's overrides, choose mode, grid and backend, render, write
 * the image, time the stages), beside `vdbs_bake()`. Its deterministic modes use the
 * ray-march kernel (shaders/vs_render.h, one text for C and GLSL): `single` (S1 of the
 * density volume) and `baked` (S1 exactly toward the camera plus Sms from a lit VDB's ms
 * and ms_l1* grids); `reference` is the Monte-Carlo path tracer (reference.h).
 *
 * Per pixel: L = integral T(0,t) sigma_s S(x, wo) dt + T_total L_background, the constant
 * env colour as background (black without env). */
#ifndef VDBSCATTER_RENDER_H
#define VDBSCATTER_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/cancel.h"
#include "vdbscatter/image.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/litvdb.h"
#include "vdbscatter/march_session.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The presets of --quality (quality.h): sky directions 16 / 64 / 256 / 1024 and steps of
 * 1, 1/2, 1/4, 1/8 voxel for low / medium / high / ultra. Returns 0 for an unknown name. */
int vdbs_render_quality(const char *quality, vdbs_march_options *options);

/* Ray-marches frame->width x frame->height pixels into image->rgb, which the caller has
 * allocated with that size (image->se is left alone), on the runner's backend. ms NULL or
 * empty: single mode. The scene's lights are resolved once per call. On the GPU the rays
 * run in passes of options->gpu_units marches per pixel (vs_pass.h). Errors: an
 * environment map (only a constant env colour is supported), a zero sun direction. */
vdbs_status vdbs_render_march(vdbs_runner *runner, const vdbs_volume *volume,
                              const vdbs_lit_grids *ms, const vdbs_scene *scene,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              vdbs_image *image, vdbs_error *err);

typedef enum vdbs_render_mode {
    VDBS_RENDER_DEFAULT = 0, /* baked for a lit VDB, single otherwise */
    VDBS_RENDER_SINGLE,
    VDBS_RENDER_BAKED,
    VDBS_RENDER_REFERENCE
} vdbs_render_mode;

/* "single", "baked" or "reference" (NULL for the default). */
const char *vdbs_render_mode_name(vdbs_render_mode mode);

/* Which scene fields the caller set explicitly (command-line flags): for a lit VDB they
 * go on top of the scene it was baked with. */
enum {
    VDBS_SCENE_SET_DENSITY_SCALE = 1 << 0,
    VDBS_SCENE_SET_ALBEDO = 1 << 1,
    VDBS_SCENE_SET_G = 1 << 2,
    VDBS_SCENE_SET_QUALITY = 1 << 3,
    VDBS_SCENE_SET_LIGHTS = 1 << 4,
    VDBS_SCENE_SET_GRID = 1 << 5,
    VDBS_SCENE_SET_SKY_DIRECTIONS = 1 << 7,
    VDBS_SCENE_FROM_FILE = 1 << 6 /* a scene file was given: it replaces a baked scene */
};

/* Zero-initialise; 0 means "choose the default". */
typedef struct vdbs_render_desc {
    const char *input;       /* density or lit VDB; scene->volume_file when NULL */
    const char *output;      /* .exr or .png; NULL: no file (then keep_image is required) */
    const vdbs_scene *scene; /* the caller's scene (may have no lights for a lit VDB) */
    unsigned scene_set;      /* VDBS_SCENE_SET_* bits */
    vdbs_render_mode mode;
    vdbs_backend backend;      /* single/baked; reference always runs on the C path */
    const vdbs_camera *camera; /* NULL: the scene's camera, else a view of the whole volume */
    int width, height;         /* 0: the scene camera's size, else 640x480 */
    double exposure;           /* PNG only, EV */
    int gpu_units;             /* see vdbs_march_options */
    int s1_march;              /* single/baked: 1 marches to the lights (vdbs_march_options) */
    int s1_oversample;         /* light-grid oversampling; 0 = the default */
    /* baked mode: 0 renders the lit VDB as baked, S1 from its stored depths when it has them
     * (docs/lit-vdb.md), and refuses settings that change its lights or medium; 1 relights
     * it: S1 from light grids swept for the scene as given (flags on top of the baked one),
     * Sms as baked. */
    int relight;
    /* reference mode */
    int spp;           /* default 64 (4 with time_limit, 16 with tolerance) */
    double time_limit; /* seconds; 0 = one round of spp */
    double tolerance;  /* > 0: rounds until the relative noise is at most this
                          (vdbs_reference_options.tolerance) */
    int max_bounces;   /* default 1000 */
    uint64_t seed;     /* 0 is a seed like any other */
    int no_env_nee;    /* vdbs_reference_options.no_env_nee */
    int progress;      /* show progress on stderr */
    vdbs_warn_fn warn;
    void *warn_user;
    /* Polled between stages and in the render loops (cancel.h): once set, vdbs_render stops
     * with VDBS_ERR_CANCELLED and leaves no temporary image; the old picture stays unless
     * the new one was already renamed into place. NULL: never. */
    const vdbs_cancel *cancel;
    /* Bytes the render may hold (memory.h; as vdbs_bake_options.max_memory): checked once the
     * volume is loaded, before the light grids and the picture. 0: the default; < 0: none. */
    int64_t max_memory;
    /* Not NULL: the picture also comes back here on success (the caller frees it with
     * vdbs_image_free); the same floats the file holds. */
    vdbs_image *keep_image;
} vdbs_render_desc;

typedef struct vdbs_render_report {
    const char *mode; /* "single", "baked" or "reference" */
    char backend[16];
    char renderer[256];
    char grid[256];
    char quality[32];
    int width, height;
    int spp;      /* samples per pixel taken (1 for the march) */
    double noise; /* reference: the image's relative noise (vdbs_image_noise); else 0 */
    int sky_directions;
    float step_voxels;
    vdbs_camera camera;  /* as used */
    double camera_up[3]; /* the frame's up */
    double seconds_load, seconds_render, seconds_write, seconds_total;
    /* single/baked: "stored" (the lit VDB's depths), "grid" or "march", the grids'
     * oversampling (0 for stored and march), their sizes,
     * and the render split into the sweeps and the camera rays */
    char s1[8];
    int s1_oversample;
    vdbs_render_stats march_stats;
    /* As vdbs_bake_report's: the limit, the resident set once loaded, the estimate by part,
     * the peaks of the load, the render and the write. */
    int64_t memory_limit, memory_baseline;
    vdbs_memory_estimate memory_estimate;
    int64_t peak_load, peak_render, peak_write;
    int peak_per_stage;
} vdbs_render_report;

vdbs_status vdbs_render(const vdbs_render_desc *desc, vdbs_render_report *report, vdbs_error *err);

/* What a render works from, resolved once (the viewer keeps it open): the mode, the scene (a
 * lit VDB's baked scene with the caller's settings on top), the density, the ms grids
 * (baked mode), the camera (the desc's, the scene's or a view of the whole volume, with
 * the desc's size) and the quality's march options. */
typedef struct vdbs_render_input {
    vdbs_render_mode mode; /* never DEFAULT */
    int is_lit;
    int stored;            /* S1 from the lit VDB's stored depths (march.stored_depths) */
    char baked_method[32]; /* a lit VDB's bake method ("pop", ...); "" otherwise */
    vdbs_scene *scene;
    vdbs_volume volume;
    vdbs_lit_grids ms;
    vdbs_camera camera;
    vdbs_march_options march;
} vdbs_render_input;

/* desc->output is not read. Errors as vdbs_render's; on error *input is freed. */
vdbs_status vdbs_render_open(const vdbs_render_desc *desc, vdbs_render_input *input,
                             vdbs_error *err);
void vdbs_render_input_free(vdbs_render_input *input);

#ifdef __cplusplus
}
#endif

#endif
