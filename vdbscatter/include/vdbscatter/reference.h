/* The Monte-Carlo reference: unbiased path tracing of the density volume itself, all
 * scattering orders (docs/methods/reference.md). Multi-threaded C;
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

#include <stddef.h>
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
    double tolerance;  /* > 0: rounds (the first of spp samples) until the image's relative
                          noise (vdbs_image_noise) is at most this, each round sized by the
                          noise so far; with time_limit too, whichever comes first. Needs
                          image->se: without it the noise reads 0 and one round is taken */
    int max_bounces;   /* scattering events per path (>= 1); 1 = single scattering only */
    uint64_t seed;
    int no_env_nee;          /* 1: an env map is found by HG sampling alone, without next-event
                                estimation toward it (the benchmark's comparison) */
    vdbs_progress *progress; /* may be NULL; updated with the finished fraction (of the
                                pixels, of time_limit, or of the samples tolerance needs)
                                times progress->total */
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

/* A Monte-Carlo probe of the multiply-scattered source at given points: the direct oracle
 * for every solver's `ms` and `ms_l1` grids (docs/lit-vdb.md), for tests and
 * benches. With Lms(x, w) the radiance at x that has scattered at least once (and at most
 * max_bounces times), it estimates per RGB channel
 *   ms    = (1 / 4 pi) integral Lms dw       = phi_ms / 4 pi   (phi_ms: fluence)
 *   ms_l1 = (3 g / 4 pi) integral Lms w dw   = 3 g J_ms / 4 pi (J_ms: net flux vector)
 * averaged over a ball of world radius `radius` around each point (the ball average, not
 * the point value: the two differ by about radius^2 / 10 times the fluence's Laplacian).
 *
 * Estimator: light tracing with a track-length tally. Photons leave the lights, chosen
 * at random in proportion to their power (the mean of its RGB channels), and are tracked
 * with the renderer's delta tracking, analog collisions weighted by the RGB albedo, exact
 * HG sampling and Russian roulette after the third scattering event:
 *   - a sun: from a point uniform over a disc perpendicular to its travel direction that
 *     covers the bounding sphere (radius R) of the volume's support box, power E pi R^2;
 *   - a constant sky (the scene's env colours): travel direction uniform over the sphere,
 *     start point on such a disc, power 4 pi L pi R^2;
 *   - an environment map: travel direction drawn from the map's luminance x solid angle
 *     distribution (envmap.h), weight texel radiance / pdf x pi R^2 (the map as lighting,
 *     its texels, as in the reference renderer);
 *   - a point light: from its position, direction uniform, power 4 pi I; the renderer's
 *     clamp of 1/r^2 at half a voxel is honoured by scaling a photon whose first collision
 *     lies at r < r_min by (r / r_min)^2.
 * Suns with angular_diameter_deg > 0 are delta lights, as in the renderer. After the
 * first scattering event every straight flight (to the next real collision, or out of the
 * volume to infinity) adds, for each ball it crosses, weight x chord length / ball volume
 * to that ball's fluence and weight x chord x direction / volume to its flux. A path ends
 * at a collision after max_bounces scattering events (that flight still counts), when
 * roulette kills it, or at the renderer's step guard (its last flight is then lost).
 * Balls are found through a uniform grid of the points, so many points cost little more
 * than a few.
 *
 * Standard errors: the photons are split into batches fixed by their count alone (at
 * most 4096 photons each, at least 64 batches when there are 64 photons or more). With
 * X_k the sum of the scores of batch k's m_k photons, N photons in K batches,
 * S1 = sum X_k and S2 = sum X_k^2 / m_k, the estimate is S1 / N, the per-photon variance
 * (S2 - S1^2 / N) / (K - 1) (unbiased for batches of any sizes) and se = sqrt(variance /
 * N); 0 with a single batch. Results are bit-identical for a seed whatever the thread
 * count: random streams are keyed by photon index, and batches are merged in their order
 * (a finished batch waits, sparse, for the ones before it; no thread waits).
 *
 * Memory: about 260 bytes per point per thread, 500 per point, and the finished batches
 * waiting to merge (250 bytes per point a batch touched). */
typedef struct vdbs_reference_probe_options {
    int64_t photons;         /* photons traced from all lights together; 0: 1 << 20 */
    double radius;           /* world radius of the probe balls; 0: 2 x the mean voxel size */
    int max_bounces;         /* scattering events per photon path; 0: 1000 (as render's) */
    uint64_t seed;           /* 0 is a seed like any other */
    vdbs_progress *progress; /* may be NULL; updated with the finished fraction of the
                                photons times progress->total */
} vdbs_reference_probe_options;

/* Probes `count` world-space points (points[3 i + a], a = x, y, z). Outputs (each may be
 * NULL; the caller allocates them):
 *   ms[3 i + c]          ms of point i, channel c (R, G, B)
 *   ms_l1[9 i + 3 a + c] component a (x, y, z) of ms_l1 of point i, channel c: the values
 *                        of the lit VDB's grid ms_l1x (a = 0), ms_l1y, ms_l1z at point i
 *   ms_se, ms_l1_se      their standard errors, in the same layouts
 * With g = 0, ms_l1 and its se are 0. `options` may be NULL (all defaults). All lights
 * are supported (suns, point lights, constant skies and an environment map); a scene
 * without light gives zeros. Errors (VDBS_ERR_INPUT): negative photons, radius or
 * max_bounces, a radius or point that is not finite, count > 0 with points NULL; an
 * environment map that cannot be used (lights.h); out of memory. */
vdbs_status vdbs_reference_probe(const vdbs_volume *volume, const vdbs_scene *scene,
                                 const vdbs_reference_probe_options *options, const double *points,
                                 size_t count, double *ms, double *ms_l1, double *ms_se,
                                 double *ms_l1_se, vdbs_error *err);

/* The probe's estimates, each NULL or count times its width (the caller allocates them):
 *   ms[3 i + c], ms_l1[9 i + 3 a + c]  as vdbs_reference_probe's;
 *   ms_t2[18 i + 3 k + c]  the second moment (1 / 4 pi) integral Lms w_a w_b dw, component
 *                          k = xx, yy, zz, xy, xz, yz of channel c: its trace is ms, and with
 *                          n the direction of ms_l1 its part along n gives the second
 *                          Legendre moment of the light's direction (docs/lit-vdb.md);
 *   ms_se, ms_l1_se, ms_t2_se  their standard errors, in the same layouts. */
typedef struct vdbs_reference_probe_outputs {
    double *ms, *ms_l1, *ms_t2;
    double *ms_se, *ms_l1_se, *ms_t2_se;
} vdbs_reference_probe_outputs;

/* vdbs_reference_probe with the second moment as well (outputs may be NULL: nothing). */
vdbs_status vdbs_reference_probe_moments(const vdbs_volume *volume, const vdbs_scene *scene,
                                         const vdbs_reference_probe_options *options,
                                         const double *points, size_t count,
                                         const vdbs_reference_probe_outputs *outputs,
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
