/* What a solver reads and writes: the context the bake hands to a solver's run function
 * (solver.h), kept apart from the table so that the solvers never include the table that
 * calls them. */
#ifndef VDBSCATTER_SOLVE_H
#define VDBSCATTER_SOLVE_H

#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/single.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

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

#ifdef __cplusplus
}
#endif

#endif
