/* The radiance toward the scene's camera (docs/lit-vdb.md: grid radiance_view,
 * written only when the scene has a camera): S(x, wo) = S1(x, wo) + Sms(x, wo) at every
 * output voxel, wo the unit direction from the voxel centre to the camera. S1 takes the
 * exact phase of every light and sky ordinate (single.h); Sms is reconstructed from the
 * solver's ms and ms_l1 with the render's rule (shaders/vs_phase.h vs_ms_channel: exact
 * for one HG lobe per voxel). */
#ifndef VDBSCATTER_VIEW_H
#define VDBSCATTER_VIEW_H

#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* wo per output voxel (3 floats each, coords order) toward the world point `eye`; a voxel
 * whose centre is the eye gets +Z. Returns NULL when out of memory (free() the result). */
float *vdbs_view_directions(const vdbs_volume *volume, const double eye[3]);

/* Adds Sms(x, wo) from ms and ms_l1[3] (the lit VDB's layouts) to view. */
void vdbs_view_add_ms(const vdbs_volume *volume, const float *wo, const float *ms,
                      float *const ms_l1[3], float *view);

#ifdef __cplusplus
}
#endif

#endif
