/* The camera's importance (Elek et al. 2014, Sec. 5.2): which sky directions
 * the picture of the medium depends on, so that POP's few sky ordinates go where they matter.
 *
 * Importance is light emitted by the camera (duality): a frustum grid (vdbscatter/radial.h,
 * perspective, 16 x 16 texels times 16 shells growing with distance: "a regular grid
 * perspective-warped into the camera frustum") is seeded with the camera rays' first-scattered
 * importance, every pixel alike, and propagated by POP's gather (shaders/vs_pop.h, on the
 * runner). Its accumulated lobes are then projected onto a 32 x 16 lat-long map: sky light
 * arriving from w at a cell scatters into the cell's importance, so
 *   M(w) = sum over cells of V sigma_s Phi_W f_hg(w . d, a) T(cell, w),
 * Phi_W the cell's accumulated importance fluence, a its lobe's anisotropy about the cell's
 * direction from the camera d, T the transmittance from the cell towards w (a march through a
 * 16-cell coarse medium). The map is scaled to mean 1 over the sphere and mixed with a floor,
 * 0.1 + 0.9 M / mean, so that no direction loses all its probability: sampling from the sky
 * times the map stays a consistent quadrature (envmap.h). */
#ifndef VDBSCATTER_IMPORTANCE_H
#define VDBSCATTER_IMPORTANCE_H

#include "vdbscatter/envmap.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VDBS_IMPORTANCE_MAP_WIDTH 32
#define VDBS_IMPORTANCE_MAP_HEIGHT 16
#define VDBS_IMPORTANCE_GRID 16   /* texels across and shells of the frustum grid */
#define VDBS_IMPORTANCE_FLOOR 0.1 /* the map's floor, relative to its mean */

typedef struct vdbs_importance_stats {
    long long cells; /* of the frustum grid */
    int iterations;  /* of its propagation */
    double seconds_propagate;
    double seconds_project;
} vdbs_importance_stats;

/* The importance map of the scene's camera over the volume, as a 32 x 16 lat-long map whose
 * three channels hold M (allocated here: vdbs_envmap_free). box: the box-filtered medium.
 * Errors: no camera in the scene (VDBS_ERR_INPUT, naming --pop-importance), out of memory,
 * GPU errors. */
vdbs_status vdbs_importance_map(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, const vdbs_medium_box *box,
                                vdbs_envmap *map, vdbs_importance_stats *stats, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
