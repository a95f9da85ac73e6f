/* The exact single-scattering pass (S1): transmittance to every sun and point light,
 * and to the constant sky through a fixed quadrature of K directions, for every output
 * voxel. One kernel source (shaders/vs_single.h) runs in C and in a compute shader. */
#ifndef VDBSCATTER_SINGLE_H
#define VDBSCATTER_SINGLE_H

#include <stddef.h>

#include "vdbscatter/gpu.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* K unit directions spread evenly over the sphere (spherical Fibonacci lattice), equal
 * weights 4 pi / K; `dirs` holds 3 K doubles. */
void vdbs_sphere_directions(int count, double *dirs);

/* The kernel's light table (4 floats per entry, layout in shaders/vs_single.h) for a
 * volume and scene, with `sky_directions` quadrature directions for a constant sky.
 * *data is malloc'd. Errors: an environment map (not supported by this pass yet). */
vdbs_status vdbs_single_light_table(const vdbs_volume *volume, const vdbs_scene *scene,
                                    int sky_directions, float **data, size_t *entries,
                                    vdbs_error *err);

/* Direction-averaged S1 for every output voxel of the volume: radiance holds
 * 3 * volume->coord_count floats (RGB per voxel, in coords order). */
vdbs_status vdbs_single_scatter_cpu(const vdbs_volume *volume, const vdbs_scene *scene,
                                    int sky_directions, float *radiance,
                                    vdbs_progress *progress, vdbs_error *err);
vdbs_status vdbs_single_scatter_gpu(vdbs_gpu *gpu, const vdbs_volume *volume,
                                    const vdbs_scene *scene, int sky_directions,
                                    float *radiance, vdbs_progress *progress,
                                    vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
