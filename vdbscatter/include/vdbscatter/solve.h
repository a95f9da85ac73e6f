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
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What a solver reads and writes; the bake owns every buffer. */
typedef struct vdbs_solve {
    vdbs_runner *runner;
    const vdbs_volume *volume;
    const vdbs_scene *scene;
    const vdbs_light_table *lights; /* ordinates per the quality preset */
    const vdbs_quality *quality;
    const vdbs_light_grid_desc *s1_grids; /* S1 from light grids; NULL: the exact march */
    vdbs_progress *progress;
    vdbs_s1_stats *s1_stats; /* filled when S1 comes from light grids; may be NULL */
    /* The solver's state (solver.h vdbs_solver_state): --warm-start's, or NULL; and
     * --keep-state's to fill, or NULL. */
    const void *warm;
    void *keep;
    /* Outputs, 3 floats per output voxel (coords order), zeroed by the caller. */
    float *radiance;      /* S1 + Sms direction average */
    float *ms;            /* Sms direction average */
    float *ms_l1[3];      /* first moment of Sms, x / y / z components per channel */
    float *radiance_view; /* S1 toward the scene's camera (camera_radiance.h), NULL without one; the
                             bake adds Sms toward it after the solver */
    /* Per light of the table (direct lights, then sky ordinates), zeroed: vdbs_solve_s1 fills
     * it with the samples of that light's light grid (the lit VDB's stored depths). NULL: not
     * kept. */
    vdbs_light_grid_samples *light_depths;
    /* (ms and ms_l1 alias one array when the solver's writes_ms is 0) */
} vdbs_solve;

/* The S1 every solver starts from: into radiance (and toward the camera), and with
 * light_depth every light's optical depth (vdbs_s1_outputs). From light grids, or by the exact
 * march (then a second, light-grid pass gives the outputs the march has none of). */
vdbs_status vdbs_solve_s1(const vdbs_solve *solve, vdbs_s1_light_fn light_depth, void *light_user,
                          vdbs_error *err);

/* --warm-start: vec3 grid `grid` of a --keep-state bake's lit VDB at every output voxel of
 * `volume` into `out` (3 floats per voxel, coords order; (0, 0, 0) where the file has no
 * value). By index where the file's grid has the volume's transform; else at the file's voxel
 * nearest each output voxel's world centre, so that frames whose grid origin moves (the same
 * voxel size, another index of the same world point) still line up. Errors (VDBS_ERR_INPUT,
 * naming --warm-start): no such grid, a singular transform. */
vdbs_status vdbs_solve_state_vec3(const vdbio_lit *lit, const char *grid, const vdbs_volume *volume,
                                  float *out, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
