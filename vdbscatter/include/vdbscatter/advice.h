/* A scene measured against its volume before any work: the density scale that gives a
 * chosen mean optical depth (--density-scale auto:TAU, info --target-depth), and one-line
 * warnings for scenes that are almost certainly a mistake (a black or invisible bake, or
 * single scattering where multiple scattering dominates). */
#ifndef VDBSCATTER_ADVICE_H
#define VDBSCATTER_ADVICE_H

#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The warnings' bounds on the mean optical depth through the volume. */
#define VDBS_ADVICE_DEPTH_THIN 0.1
#define VDBS_ADVICE_DEPTH_THICK 1e4

/* Mean optical depth through the volume at density scale 1: the mean over the three index
 * axes of vdbs_volume_thickness's axis means (straight rays that meet density). 0 for a
 * volume without density. Optical depth is linear in the scale, so the scale for a mean
 * depth TAU is TAU / this. */
double vdbs_volume_mean_depth(const vdbs_volume *volume);

/* With scene->density_target_depth > 0, sets scene->density_scale to the scale whose mean
 * optical depth through `volume` is that target, and the target to 0 (the scene then says
 * what was used). VDBS_ERR_INPUT when the volume holds no density to scale. */
vdbs_status vdbs_scene_fit_density(vdbs_scene *scene, const vdbs_volume *volume, vdbs_error *err);

typedef struct vdbs_advice {
    double mean_depth; /* through the volume at the scene's density scale */
    double ms_to_ss;   /* estimated multiple / single scattered power (see advice.c) */
    int zero_lights;   /* lights whose colour (or map scale) is 0 */
} vdbs_advice;

/* Measures the scene on its volume into *out and gives each warning that applies once
 * through warn (may be NULL): density scale 0; a zero light, or every light zero; a mean
 * optical depth under VDBS_ADVICE_DEPTH_THIN or over VDBS_ADVICE_DEPTH_THICK; and, for a
 * solver without multiple scattering (multiple_scattering 0), an estimated ms_to_ss above 1. */
void vdbs_scene_advise(const vdbs_scene *scene, const vdbs_volume *volume, int multiple_scattering,
                       vdbs_warn_fn warn, void *warn_user, vdbs_advice *out);

#ifdef __cplusplus
}
#endif

#endif
