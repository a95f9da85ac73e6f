/* Deterministic ray-marched pictures: `--mode single` (S1 of the density volume) and
 * `--mode baked` (S1 exactly toward the camera plus Sms from a lit VDB's ms and ms_l1*
 * grids). One kernel source (shaders/vs_render.h) for the compute shader
 * (shaders/render_march.comp) and the C path, reused later by the viewer.
 *
 * Per pixel: L = integral T(0,t) sigma_s S(x, wo) dt + T_total L_background, the constant
 * env colour as background (black without env). See shaders/vs_render.h for the
 * integration rule and the kernel's table layout. */
#ifndef VDBSCATTER_RENDER_H
#define VDBSCATTER_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/gpu.h"
#include "vdbscatter/image.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Multiple-scattering grids of a lit VDB as NanoVDB Vec3f buffers (32-byte aligned, sizes
 * multiples of 32), on the density's index space. All four are set or all are NULL
 * (Sms is then 0: single mode). */
typedef struct vdbs_ms_grids {
    uint32_t *ms, *l1x, *l1y, *l1z;
    size_t ms_size, l1x_size, l1y_size, l1z_size;
} vdbs_ms_grids;

/* Converts the lit VDB's `ms`, `ms_l1x`, `ms_l1y`, `ms_l1z` grids. `index_to_world` is the
 * density grid's transform (vdbs_volume.index_to_world), which every grid must share: the
 * kernel samples them in the density's index space. Errors (VDBS_ERR_INPUT): a grid
 * missing or not vec3s, or on another transform. */
vdbs_status vdbs_ms_grids_load(const vdbio_lit *lit, const double index_to_world[3][4],
                               vdbs_ms_grids *out, vdbs_error *err);
void vdbs_ms_grids_free(vdbs_ms_grids *grids);

typedef struct vdbs_march_options {
    int sky_directions;      /* quadrature directions for the sky's S1 (>= 1) */
    float step_voxels;       /* camera-ray segment length in voxels (> 0; quality knob) */
    vdbs_progress *progress; /* may be NULL; counts finished pixels */
    /* GPU only: units of work (marches) per pixel and dispatch; 0 = chosen from the grid
     * size so that a dispatch stays within llvmpipe's loop limit. Tests set it to check
     * the resumption (1) and the limit detection (huge). */
    int gpu_units;
} vdbs_march_options;

/* The presets of --quality: sky directions 16 / 64 / 256 / 1024 and steps of 1, 1/2, 1/4,
 * 1/8 voxel for low / medium / high / ultra. Returns 0 for an unknown name. */
int vdbs_render_quality(const char *quality, vdbs_march_options *options);

/* The kernel's table (4 floats per entry, layout in shaders/vs_render.h), *data malloc'd.
 * ms may be NULL. Errors: an environment map (only a constant env colour is supported),
 * a zero sun direction, bad options, grids beyond the 2^36-byte offset range. */
vdbs_status vdbs_render_table(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                              const vdbs_scene *scene, const vdbs_camera_frame *frame,
                              const vdbs_march_options *options, float **data, size_t *entries,
                              vdbs_error *err);

/* The buffer both paths read: the density grid at byte 0 followed by ms, l1x, l1y, l1z
 * (when ms is not NULL and set). When there are no ms grids, *buffer is volume->nano and
 * *owned is 0; otherwise a new allocation that the caller frees. */
vdbs_status vdbs_render_buffer(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                               uint32_t **buffer, size_t *size, int *owned, vdbs_error *err);

/* Renders frame->width x frame->height pixels into image->rgb, which the caller has
 * allocated with that size (image->se is left alone). ms NULL or empty: single mode. */
vdbs_status vdbs_render_march_cpu(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                                  const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                  const vdbs_march_options *options, vdbs_image *image,
                                  vdbs_error *err);
/* The GPU path runs the rays in passes of options->gpu_units marches per pixel, keeping
 * each ray's state between passes (llvmpipe ends all loops of an invocation after 65535
 * iterations in total; see shaders/render_march.comp); a pass that reached the limit
 * anyway is detected and repeated with half the units. */
vdbs_status vdbs_render_march_gpu(vdbs_gpu *gpu, const vdbs_volume *volume, const vdbs_ms_grids *ms,
                                  const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                  const vdbs_march_options *options, vdbs_image *image,
                                  vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
