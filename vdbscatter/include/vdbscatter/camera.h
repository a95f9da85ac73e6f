/* Pinhole cameras (docs/design.md "Physical conventions"): fov_deg is the vertical field of view,
 * up defaults to +Y, right = forward x up, image row 0 is the top, rays go through pixel
 * centres (+0.5), and the observer direction is wo = -ray direction. */
#ifndef VDBSCATTER_CAMERA_H
#define VDBSCATTER_CAMERA_H

#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Ready-to-use camera frame: a ray through image point (px, py) (pixels, row 0 on top,
 * pixel centres at +0.5) starts at origin with direction
 * normalize(forward + (2 px / width - 1) * tan_half_x * right
 *           + (1 - 2 py / height) * tan_half_y * up). */
typedef struct vdbs_camera_frame {
    double origin[3];
    double forward[3];
    double right[3];
    double up[3];
    double tan_half_x;
    double tan_half_y;
    int width;
    int height;
} vdbs_camera_frame;

/* Builds the frame of a scene camera. Errors: degenerate camera (already refused by
 * vdbs_scene_validate). */
vdbs_status vdbs_camera_frame_init(const vdbs_camera *camera, vdbs_camera_frame *frame,
                                   vdbs_error *err);

/* A camera that frames the world-space bounding box of the volume's active voxels (grown
 * by one voxel) from +Z, slightly above, fov 35 degrees, with the given image size. */
void vdbs_camera_frame_volume(const vdbs_volume *volume, int width, int height,
                              vdbs_camera *camera);

/* World-space unit direction of the ray through image point (px, py). */
void vdbs_camera_ray(const vdbs_camera_frame *frame, double px, double py, double dir[3]);

#ifdef __cplusplus
}
#endif

#endif
