/* The Monte-Carlo reference: unbiased path tracing of the density volume itself, all
 * scattering orders (DESIGN.md "Accuracy: the Monte-Carlo reference"). Multi-threaded C;
 * deterministic for a seed whatever the thread count (random streams are keyed by pixel
 * and sample index).
 *
 * Method: delta tracking of collisions against a majorant grid (the maximum of sigma_t
 * over each 4^3-voxel region, grown by the one voxel that the trilinear interpolant
 * reaches, walked with a DDA; coarser for huge grids), ratio tracking for shadow rays,
 * next-event estimation to suns and point lights at every scattering vertex, exact
 * inverse-CDF sampling of the HG phase, analog collisions weighted by the RGB albedo, and
 * Russian roulette on the throughput after the third scattering event (survival
 * probability = the largest channel of the throughput, so a path of throughput 1 is never
 * killed and albedo 1 stays unbiased). A constant env light is seen by paths that leave
 * the volume (after the last allowed scattering event: along a phase-sampled direction,
 * weighted by its ratio-tracked transmittance). Suns with angular_diameter_deg > 0 are
 * treated as delta lights (the disc is not sampled). Random numbers are a counter-based
 * hash of (seed, pixel, sample) and a counter. A path ends after 2^22 tracking steps in
 * total (collisions, null collisions and shadow-ray steps; about a million scattering
 * events): a guard against endless random walks when max_bounces is huge in optically
 * huge, non-absorbing media. Its remaining energy is lost (the tally counts it absorbed). */
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
    int spp;           /* samples per pixel (>= 1); with time_limit > 0, samples per round */
    double time_limit; /* seconds; > 0: render rounds of spp samples (doubled while a round
                          takes under 1/50 of the limit) as long as the next one fits in
                          the time left (at least one round) */
    int max_bounces;   /* scattering events per path (>= 1); 1 = single scattering only */
    uint64_t seed;
    int no_env_nee;          /* 1: an env map is found by HG sampling alone, without next-event
                                estimation toward it (the benchmark's comparison) */
    vdbs_progress *progress; /* may be NULL; updated with the finished fraction (of the
                                pixels, or of time_limit) times progress->total */
} vdbs_reference_options;

/* Renders the image seen by `frame` through pixel centres: rgb = mean radiance of the
 * samples, se = its standard error per pixel and channel, sqrt(var / n) with the sample
 * variance of the per-sample estimates (0 when only one sample was taken). The caller
 * allocates `image` at frame->width x frame->height (vdbs_image_alloc); se may be NULL
 * (then not written). Rays that leave the volume see the env light (black without one).
 * *spp_done (may be NULL) receives the samples taken per pixel.
 * Errors: an environment map (VDBS_ERR_INPUT, not supported yet), spp or max_bounces < 1
 * (VDBS_ERR_INPUT), an image of the wrong size (VDBS_ERR_INTERNAL), out of memory. */
vdbs_status vdbs_reference_render(const vdbs_volume *volume, const vdbs_scene *scene,
                                  const vdbs_camera_frame *frame,
                                  const vdbs_reference_options *options, vdbs_image *image,
                                  int *spp_done, vdbs_error *err);

/* Energy tallies for tests: `paths` photons of the scene's first sun enter through the
 * world-space disc of `radius` around `centre`, perpendicular to the sun; each starts on
 * the sun's side of the volume, outside its support box. A photon carries the weight 1,
 * multiplied by albedo[0] (the red channel) at each collision and changed by Russian
 * roulette as in the renderer. Each weight ends as escaped, classified by the sign of the
 * final direction's dot product with the sun direction (reflected < 0, transmitted >= 0,
 * photons that miss the volume included), or absorbed: the weight lost at collisions
 * (1 - albedo of it each time), plus the weight of paths ended by max_bounces (a collision
 * after the last allowed scattering event) or by the step guard. Fractions of the launched
 * energy with their standard errors; reflected + transmitted + absorbed = 1 in
 * expectation (exactly per photon without roulette). */
typedef struct vdbs_reference_tally {
    double reflected, transmitted, absorbed;
    double reflected_se, transmitted_se, absorbed_se;
    /* Fraction of the launched energy that escapes through a face of the index-space
     * support box other than the two faces whose world-space normal is most nearly
     * parallel to the sun (the entry face and the one opposite it): what leaks out of
     * the sides of a slab lit along its normal. */
    double side_leak;
} vdbs_reference_tally;

/* Errors: no sun in the scene, paths < 1, max_bounces < 1, radius < 0 (VDBS_ERR_INPUT). */
vdbs_status vdbs_reference_tally_sun(const vdbs_volume *volume, const vdbs_scene *scene,
                                     const double centre[3], double radius, int64_t paths,
                                     int max_bounces, uint64_t seed, vdbs_reference_tally *tally,
                                     vdbs_error *err);

/* The cosine mu between incident and scattered propagation directions drawn from the HG
 * phase of anisotropy g for a uniform number u in [0, 1): the exact inverse of its CDF,
 * in a form without division by g (finite and accurate for g = 0 and |g| <= 0.999); the
 * sampler the reference uses, vs_hg_sample_d of shaders/vs_phase.h. */
double vdbs_reference_hg_sample(double g, double u);

#ifdef __cplusplus
}
#endif

#endif
