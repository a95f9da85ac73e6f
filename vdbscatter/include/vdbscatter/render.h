/* Deterministic ray-marched pictures: `--mode single` (S1 of the density volume) and
 * `--mode baked` (S1 exactly toward the camera plus Sms from a lit VDB's ms and ms_l1*
 * grids). One kernel source for the compute shader and the C path, reused later by the
 * viewer. */
#ifndef VDBSCATTER_RENDER_H
#define VDBSCATTER_RENDER_H

#include "vdbscatter/camera.h"
#include "vdbscatter/gpu.h"
#include "vdbscatter/image.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Multiple-scattering grids of a lit VDB as NanoVDB Vec3f buffers (NULL when absent:
 * Sms is then 0). All four are present or absent together. */
typedef struct vdbs_ms_grids {
    uint32_t *ms, *l1x, *l1y, *l1z;
    size_t ms_size, l1x_size, l1y_size, l1z_size;
} vdbs_ms_grids;

typedef struct vdbs_march_options {
    int sky_directions;     /* quadrature directions for the sky's S1 */
    float step_voxels;      /* camera-ray sample spacing in voxels (quality knob) */
    vdbs_progress *progress;
} vdbs_march_options;

vdbs_status vdbs_render_march_cpu(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                                  const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                  const vdbs_march_options *options, vdbs_image *image,
                                  vdbs_error *err);
vdbs_status vdbs_render_march_gpu(vdbs_gpu *gpu, const vdbs_volume *volume,
                                  const vdbs_ms_grids *ms, const vdbs_scene *scene,
                                  const vdbs_camera_frame *frame,
                                  const vdbs_march_options *options, vdbs_image *image,
                                  vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
