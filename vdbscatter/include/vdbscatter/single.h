/* The exact single-scattering pass (S1): transmittance to every sun and point light, and
 * to the sky through the light table's ordinates, for every output voxel. One kernel source
 * (shaders/vs_single.h) runs on either backend of the runner. */
#ifndef VDBSCATTER_SINGLE_H
#define VDBSCATTER_SINGLE_H

#include "vdbscatter/runner.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Direction-averaged S1 for every output voxel of the volume: radiance holds
 * 3 * volume->coord_count floats (RGB per voxel, in coords order). The scene gives the
 * medium; the lights were built for this volume. progress may be NULL. */
vdbs_status vdbs_single_scatter(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, const vdbs_light_table *lights,
                                float *radiance, vdbs_progress *progress, vdbs_error *err);

/* Kinds of light, as the S1 stats split them. */
typedef enum vdbs_s1_kind { VDBS_S1_SUN, VDBS_S1_POINT, VDBS_S1_SKY, VDBS_S1_KINDS } vdbs_s1_kind;

/* What one kind of light's grids cost. */
typedef struct vdbs_s1_kind_stats {
    int lights;
    vdbs_light_grid_stats grids; /* summed over them (spacings: smallest and largest) */
    double seconds_lookup;
} vdbs_s1_kind_stats;

/* What S1 from light grids cost. */
typedef struct vdbs_s1_stats {
    vdbs_light_grid_stats grids; /* summed over the lights */
    double seconds_lookup;       /* lookups and accumulation */
    vdbs_s1_kind_stats kinds[VDBS_S1_KINDS];
} vdbs_s1_stats;

/* The same S1 from light grids (lightgrid.h): a directional grid per sun and sky ordinate
 * and a radial grid per point light, each built by one transmittance sweep and looked up at
 * every output voxel, one light at a time: cost linear in the voxels per light direction
 * instead of a march per voxel and light. stats may be NULL. */
vdbs_status vdbs_single_scatter_grids(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_scene *scene, const vdbs_light_table *lights,
                                      const vdbs_light_grid_desc *grids, float *radiance,
                                      vdbs_s1_stats *stats, vdbs_progress *progress,
                                      vdbs_error *err);

/* Called once per light (direct lights, then sky ordinates) with the optical depth toward it
 * at every output voxel. */
typedef void (*vdbs_s1_light_fn)(void *user, int light, const float *depth);
/* Called once per light, before vdbs_s1_light_fn, with its light grid (a set of one). Returns
 * a status: an error stops the pass. */
typedef vdbs_status (*vdbs_s1_grid_fn)(void *user, int light, const vdbs_light_grids *grid,
                                       vdbs_error *err);

/* What the light-grid S1 pass writes, 3 floats per output voxel unless said; each may be
 * NULL. */
typedef struct vdbs_s1_outputs {
    float *radiance;      /* S1, the fluence of the unscattered light over 4 pi */
    float *radiance_view; /* S1 toward the scene's camera (camera_radiance.h; the scene must have
                             one): per light its fluence times HG(g) between its direction of travel
                             and wo */
    /* For solvers that need each light's own unscattered light (the discrete ordinates' first
     * scattering); NULL: none. */
    vdbs_s1_light_fn light_depth;
    void *light_user;
    vdbs_s1_grid_fn light_grid; /* NULL: none; called with light_user */
} vdbs_s1_outputs;

/* The same pass writing any of the outputs. */
vdbs_status vdbs_single_scatter_grids_out(vdbs_runner *runner, const vdbs_volume *volume,
                                          const vdbs_scene *scene, const vdbs_light_table *lights,
                                          const vdbs_light_grid_desc *grids,
                                          const vdbs_s1_outputs *out, vdbs_s1_stats *stats,
                                          vdbs_progress *progress, vdbs_error *err);

/* What vdbs_single_scatter_grids_out allocates beside its light grids (built one light at a
 * time; vdbs_light_grids_estimate's peak_one): per-voxel sums, and with a camera the view's. */
int64_t vdbs_single_scatter_grids_bytes(const vdbs_volume *volume, int camera);

#ifdef __cplusplus
}
#endif

#endif
