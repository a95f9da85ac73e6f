/* Solvers as a table: each bake method is one entry (name, summary, run function) and the
 * quality presets that every method and the render march read live here once. Adding a
 * solver is adding an entry to the table in solver.c plus its kernels. */
#ifndef VDBSCATTER_SOLVER_H
#define VDBSCATTER_SOLVER_H

#include <stddef.h>

#include "vdbscatter/kernel.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/single.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One step of the quality knob. */
typedef struct vdbs_quality {
    const char *name;         /* "low", "medium", "high", "ultra" */
    int sky_directions;       /* quadrature directions for the sky's S1: 16 / 64 / 256 / 1024 */
    float render_step_voxels; /* camera-ray step of the render march: 1, 1/2, 1/4, 1/8 voxel */
    int s1_oversample;        /* S1 light-grid samples per smallest voxel: 1 / 1 / 2 / 2
                                 (bench/defaults.md: 2 costs up to 5x the bake for no
                                 measurable gain at low and medium) */
} vdbs_quality;

/* The preset of a quality name, or NULL if unknown. */
const vdbs_quality *vdbs_quality_find(const char *name);
/* The quality ladder, low to ultra. */
const vdbs_quality *vdbs_quality_list(int *count);
/* The quality's step, 0 (low) to 3 (ultra): the index into a solver's own presets; medium's
 * (1) for NULL or an unknown name. */
int vdbs_quality_level(const char *name);
/* Number of sky quadrature directions for a quality name, or 0 if unknown. */
int vdbs_quality_sky_directions(const char *name);

typedef enum vdbs_method {
    VDBS_METHOD_SINGLE = 0,
    VDBS_METHOD_POP,
    VDBS_METHOD_FLD,
    VDBS_METHOD_SVD,
    VDBS_METHOD_COUNT
} vdbs_method;

struct vdbs_pop_stats;
struct vdbs_fld_stats;
struct vdbs_svd_stats;
struct vdbs_svd_moments;

/* What a solver reads and writes; the bake owns every buffer. */
typedef struct vdbs_solve {
    vdbs_runner *runner;
    const vdbs_volume *volume;
    const vdbs_scene *scene;
    const vdbs_light_table *lights; /* ordinates per the quality preset */
    const vdbs_quality *quality;
    const vdbs_light_grid_desc *s1_grids; /* S1 from light grids; NULL: the exact march */
    vdbs_progress *progress;
    vdbs_s1_stats *s1_stats;          /* filled when S1 comes from light grids; may be NULL */
    struct vdbs_pop_stats *pop_stats; /* filled by POP; may be NULL */
    struct vdbs_fld_stats *fld_stats; /* filled by FLD; may be NULL */
    struct vdbs_svd_stats *svd_stats; /* filled by the discrete ordinates; may be NULL */
    const struct vdbs_svd_moments *svd_warm; /* --warm-start, or NULL */
    struct vdbs_svd_moments *svd_keep;       /* --keep-state: filled, or NULL */
    /* Outputs, 3 floats per output voxel (coords order), zeroed by the caller. */
    float *radiance;      /* S1 + Sms direction average */
    float *ms;            /* Sms direction average */
    float *ms_l1[3];      /* first moment of Sms, x / y / z components per channel */
    float *radiance_view; /* S1 toward the scene's camera (view.h), NULL without one; the
                             bake adds Sms toward it after the solver */
    /* (ms and ms_l1 alias one array when the solver's writes_ms is 0) */
} vdbs_solve;

typedef struct vdbs_solver {
    vdbs_method method;
    const char *name;    /* --method */
    const char *summary; /* one line for --help */
    int writes_ms;       /* 0: ms and ms_l1 stay 0 (the bake then shares one zero array) */
    vdbs_status (*run)(const vdbs_solve *solve, vdbs_error *err);
} vdbs_solver;

/* The solver of a method name, or NULL if none is implemented under that name. */
const vdbs_solver *vdbs_solver_find(const char *name);
/* The implemented solvers, in table order. */
const vdbs_solver *vdbs_solver_list(int *count);
/* "single" or "single, pop" ...: the names for messages. */
void vdbs_solver_names(char *buf, size_t size);

#ifdef __cplusplus
}
#endif

#endif
