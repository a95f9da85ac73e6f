/* The Monte-Carlo reference: unbiased path tracing of the density volume itself, all
 * scattering orders (DESIGN.md "Accuracy: the Monte-Carlo reference"). Multi-threaded C;
 * deterministic for a seed whatever the thread count (random streams are keyed by pixel
 * and sample index). */
#ifndef VDBSCATTER_REFERENCE_H
#define VDBSCATTER_REFERENCE_H

#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/image.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_reference_options {
    int spp;            /* samples per pixel (>= 1) unless time_limit > 0 */
    double time_limit;  /* seconds; > 0: render passes of spp_step until the time is spent */
    int max_bounces;    /* scattering events per path; 1 = single scattering only */
    uint64_t seed;
    vdbs_progress *progress; /* may be NULL */
} vdbs_reference_options;

/* Renders the image seen by `frame`: rgb = mean radiance, se = standard error per pixel.
 * Rays that leave the volume see the env light (black without one). */
vdbs_status vdbs_reference_render(const vdbs_volume *volume, const vdbs_scene *scene,
                                  const vdbs_camera_frame *frame,
                                  const vdbs_reference_options *options, vdbs_image *image,
                                  int *spp_done, vdbs_error *err);

/* Energy tallies for tests: `paths` photons of the scene's first sun enter through the
 * world-space disc of `radius` around `centre`, perpendicular to the sun, starting outside
 * the volume (centre is moved back along the sun until outside the support box). Each
 * ends as escaped (classified by the sign of its final direction's dot product with the
 * sun direction: reflected < 0, transmitted >= 0) or absorbed. Fractions of the launched
 * energy with their standard errors; photons that leave sideways are still counted by
 * direction, so tests keep their geometry wide enough. */
typedef struct vdbs_reference_tally {
    double reflected, transmitted, absorbed;
    double reflected_se, transmitted_se, absorbed_se;
    double side_leak; /* fraction escaping through the support box's faces parallel to the sun... */
} vdbs_reference_tally;

vdbs_status vdbs_reference_tally_sun(const vdbs_volume *volume, const vdbs_scene *scene,
                                     const double centre[3], double radius, int64_t paths,
                                     int max_bounces, uint64_t seed,
                                     vdbs_reference_tally *tally, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
