/* Illumination networks (Szirmay-Kalos, Sbert, Umenhoffer; docs/methods/inet.md;
 * `--method inet`): the multiply-scattered light as the incoming radiance of N particles from D
 * global directions, iterated on the visibility network (inet_network.h) by Jacobi sweeps of
 * the paper's Eq. 2 through the kernel runner (shaders/vs_inet.h, inet_sweep.comp).
 *
 * The scene's light enters as its first scattering from the exact S1 pass's light grids: per
 * particle the light its voxel's medium collides (collision.h, cube-averaged), emitted by HG(g)
 * exactly towards each direction and normalised on the directions, rather than the paper's
 * light snapped to the nearest direction. The iteration then carries only scattered light; the
 * particles' incoming radiance gives ms and ms_l1 per particle, splatted onto a coarse grid and
 * reconstructed on the voxels as the other solvers' are (coarse.h). */
#ifndef VDBSCATTER_INET_H
#define VDBSCATTER_INET_H

#include <stdint.h>

#include "vdbscatter/inet_network.h"
#include "vdbscatter/phasemat.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/solve.h"
#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The slots of a network's state (shaders/vs_inet.h): the N D links, then a sink per particle
 * and direction with nothing after it. source: per slot (links + sinks) its source particle
 * (-1: none), then per sink its direction. */
typedef struct vdbs_inet_links {
    int64_t links, sinks;
    int32_t *source;
} vdbs_inet_links;

vdbs_status vdbs_inet_links_build(const vdbs_inet_network *net, vdbs_inet_links *links,
                                  vdbs_error *err);
void vdbs_inet_links_free(vdbs_inet_links *links);

/* One problem on a network. */
typedef struct vdbs_inet_problem {
    const vdbs_inet_network *net;
    const vdbs_inet_links *links;
    const float *phase;    /* D x D, row i the weights into w_i (phasemat.h's balanced P) */
    double opacity;        /* alpha of every particle */
    double albedo[3];      /* a per channel */
    const float *emission; /* N D x 3: E per particle and direction, or NULL */
    double inflow[3];      /* radiance entering along a link without a source */
    /* Resident ids (runner.h) for the kernel's constant inputs (parameters, sources, phase,
     * emission), or 0: uploaded with every call. */
    uint64_t resident[4];
} vdbs_inet_problem;

/* What every inet solve sets up once for a volume: the phase matrix (its directions are the
 * network's), the matrix in float for the kernel, the network and its slots. */
typedef struct vdbs_inet_setup {
    vdbs_phasemat pm;
    float *phase; /* D x D */
    vdbs_inet_network net;
    vdbs_inet_links links;
} vdbs_inet_setup;

/* The paper's phase without delta-M (the balanced matrix keeps every collision's power) for the
 * medium's g, and the network of N particles on D directions with window M (0: the rule) and
 * seed. Errors: phasemat.h's and inet_network.h's, out of memory. */
vdbs_status vdbs_inet_setup_build(const vdbs_volume *volume, double density_scale, double g,
                                  int64_t particles, int directions, int window, uint64_t seed,
                                  vdbs_inet_setup *setup, vdbs_error *err);
void vdbs_inet_setup_free(vdbs_inet_setup *setup);

/* 1 - exp(-m / A): a particle's opacity for its mass and pixel area (inet_network.h). */
double vdbs_inet_opacity(const vdbs_inet_network *net);

/* Sweeps until the sum of the slots' changes (over channels) is at most `tolerance` or
 * max_iterations have run; state (3 floats per slot) is the start in and the result out.
 * result may be NULL. Errors: the runner's. */
vdbs_status vdbs_inet_iterate(vdbs_runner *runner, const vdbs_inet_problem *pb, int max_iterations,
                              double tolerance, float *state, vdbs_progress *progress,
                              vdbs_kernel_result *result, vdbs_error *err);

/* One Gauss-Seidel line sweep on the C path, in place, through the same slot update as the
 * kernel (vs_inet.h): the directions in turn, and per direction its chains walked from their
 * heads downstream (in parallel), each slot taking its source's outgoing light from the newest
 * state, then the sinks. The fixed point is the Jacobi sweep's; where a Jacobi sweep moves
 * light one particle along a chain, this carries it through the whole volume and many
 * scatterings (the viewer's warm start, inet_live.h). downstream: N x D, the particle whose
 * upstream along d is p, or -1; scratch: N doubles. Returns the sum of the slots' changes over
 * the channels. */
double vdbs_inet_line_sweep(const vdbs_inet_problem *pb, const int32_t *downstream, float *state,
                            double *scratch);

/* How a solve (vdbs_inet_solve) ended. */
typedef struct vdbs_inet_solve_result {
    int iterations;
    double change;      /* the last sweep's total change over `reference` */
    double residual;    /* the estimated distance from the converged state over `reference` */
    double contraction; /* the mean ratio of successive changes over the last 4 sweeps */
    int converged;
} vdbs_inet_solve_result;

/* Jacobi sweeps until the estimated distance from the converged state is at most
 * residual x reference (reference: the first scattering's total): the last sweep's change c
 * times rho / (1 - rho), rho the contraction, once rho has settled below 1 over 4 sweeps (the
 * change alone stops far too early where rho is near 1, in thick media near albedo 1), or at
 * max_iterations. The constant inputs stay on the GPU between sweeps. Errors: the runner's. */
vdbs_status vdbs_inet_solve(vdbs_runner *runner, const vdbs_inet_problem *pb, int max_iterations,
                            double residual, double reference, float *state,
                            vdbs_progress *progress, vdbs_inet_solve_result *result,
                            vdbs_error *err);

/* The power balance of one sweep from `before` to `after`, in double: what the slots hold
 * after (links and sinks, less the inflow) against what the particles sent out, the radiance
 * that reached them minus what they absorbed plus what they emitted. Returns
 * |sent - held| / sent (0 when nothing was sent). */
double vdbs_inet_balance(const vdbs_inet_problem *pb, const float *before, const float *after);

/* Adds particle p's first scattering of light arriving with `irradiance` (E T, per channel)
 * travelling along `travel` (unit) into `emission` (N D x 3): its power a m E spread over the
 * directions by HG(g), normalised on them (power kept), as link radiance (over the pixel area
 * A and 4 pi / D). Not thread-safe for one p. */
void vdbs_inet_emit(const vdbs_inet_network *net, double g, const double albedo[3], int64_t p,
                    const double irradiance[3], const double travel[3], float *emission);

/* The particles' incoming radiance (`state`'s links) as docs/design.md's ms and ms_l1 on the
 * output voxels: per particle the fluence and net flux over the D directions, averaged onto a
 * coarse world grid (about 8 particles to a cell; its resolution out, may be NULL) and
 * reconstructed by the interpolating B-spline with the joint bilateral weights (coarse.h),
 * then held to the energy bound: the light ms says the medium absorbs may not exceed the power
 * scattered into the network (the problem's emission; no bound without one). Adds to ms,
 * ms_l1 and radiance (which may be NULL). Errors: out of memory. */
vdbs_status vdbs_inet_to_voxels(const vdbs_inet_problem *pb, const float *state,
                                const vdbs_volume *volume, double density_scale, double g,
                                float *ms, float *const ms_l1[3], float *radiance, int *resolution,
                                vdbs_error *err);

/* A solve's state on the output voxels (--keep-state, --warm-start, the viewer's open): per
 * direction d one grid of 3 floats per output voxel, the RGB radiance I reaching the voxel's
 * particles along w_d (the slots carry a value per colour channel, the albedo being one per
 * channel), the mean over the voxel's particles that have an upstream particle along w_d; 0
 * where none has. A chain's head holds only the inflow, whatever the state: it is neither
 * averaged nor started. Per voxel, not per particle, so that a state starts a network of
 * another seed or particle count on the same volume. A lit VDB stores it as the vec3 grids
 * inet_r0000 ... (one per direction) with the file metadata vdbscatter_inet_directions (D). */
typedef struct vdbs_inet_voxel_state {
    int directions;   /* D; 0: empty */
    size_t voxels;    /* the volume's output voxels */
    float **radiance; /* D arrays of 3 floats per output voxel (coords order) */
} vdbs_inet_voxel_state;

#define VDBS_INET_STATE_PREFIX "inet_r"
#define VDBS_INET_STATE_META "vdbscatter_inet_directions"

/* Errors: out of memory. */
vdbs_status vdbs_inet_voxel_state_alloc(vdbs_inet_voxel_state *vs, int directions, size_t voxels,
                                        vdbs_error *err);
void vdbs_inet_voxel_state_free(vdbs_inet_voxel_state *vs);
/* The network's state (links then sinks, 3 floats a slot) into vs (allocated for the network's
 * D and its volume's voxels): per voxel and direction the mean of the links' radiance over the
 * voxel's particles with an upstream particle along the direction, 0 where none. Errors: vs
 * of another D (VDBS_ERR_INTERNAL), out of memory. */
vdbs_status vdbs_inet_voxel_state_store(const vdbs_inet_network *net, const float *state,
                                        vdbs_inet_voxel_state *vs, vdbs_error *err);
/* The warm start: every particle's links that have an upstream particle take its voxel's
 * stored radiance (0 where the voxel holds none, as a cold start); the other slots (the chains'
 * heads, which hold the inflow, and the sinks, whatever the first sweep makes them) are left as
 * they are. vs has the network's D and its volume's voxels. */
void vdbs_inet_voxel_state_start(const vdbs_inet_network *net, const vdbs_inet_voxel_state *vs,
                                 float *state);
/* The D a lit VDB's inet state was solved with (its metadata, and its last grid there), or 0
 * when it holds none. */
int vdbs_inet_voxel_state_directions(const vdbio_lit *lit);
/* The state of a lit VDB (opened with at least the inet_r grids; `path` for messages) at the
 * volume's output voxels (vdbs_solve_state_vec3: by index, else through world space).
 * Errors (VDBS_ERR_INPUT, one line naming --warm-start): no inet state in it; a state for
 * another D than `directions`; out of memory. */
vdbs_status vdbs_inet_voxel_state_read(const vdbio_lit *lit, const char *path,
                                       const vdbs_volume *volume, int directions,
                                       vdbs_inet_voxel_state *vs, vdbs_error *err);

/* What a quality chooses. */
typedef struct vdbs_inet_preset {
    int64_t particles; /* 5000 at every quality (the ladder stops at low) */
    int directions;    /* 64 at every quality */
    double residual;   /* 1e-2 at every quality */
} vdbs_inet_preset;

/* The preset of a quality name (medium's for an unknown one or NULL). */
void vdbs_inet_quality(const char *quality, vdbs_inet_preset *preset);

/* Zero-initialise; 0 means the default. */
typedef struct vdbs_inet_desc {
    int64_t particles;  /* N (--inet-particles); default: the quality's */
    int directions;     /* D (--inet-directions); default: the quality's */
    int window;         /* M (--inet-window); default: vdbs_inet_window_rule */
    int max_iterations; /* cap of sweeps (--inet-iterations); default 1000 */
    double residual;    /* stop once a sweep's total change is at most this fraction of the
                           first scattering's total (--inet-residual); default: the quality's */
    uint64_t seed;      /* of the particles (--inet-seed) */
    /* --warm-start's state (the network's D, the volume's voxels), or NULL: a cold start */
    const vdbs_inet_voxel_state *warm;
    /* --keep-state's, filled (allocated here) once the solve ends, or NULL */
    vdbs_inet_voxel_state *keep;
    vdbs_progress *progress;
} vdbs_inet_desc;

typedef struct vdbs_inet_stats {
    int64_t particles;
    int directions, window, resolution;
    int paper_window; /* the paper's bound on the window (inet_network.h), reported */
    double opacity, pixel_area;
    int64_t links, sinks;
    int iterations, converged;
    int warm_start;  /* the slots started from a --warm-start state */
    double residual; /* the estimated distance from converged over the first scattering's total */
    double change;   /* the last sweep's change, the same way */
    double contraction; /* vdbs_inet_solve_result's */
    double first_total;
    double seconds_network, seconds_emission, seconds_solve, seconds_splat;
} vdbs_inet_stats;

/* The bake's solver around the S1 pass, as the discrete ordinates' (svd.h): begin, the S1 pass
 * with vdbs_inet_light_depth, finish (adds ms, ms_l1 and radiance), end. */
typedef struct vdbs_inet_run vdbs_inet_run;
/* The bytes a solve holds per output voxel (the faces, one light's first collisions and
 * their scratch, the network's per-voxel extinction) for `voxels` of them. For the bake's
 * memory estimate, with vdbs_inet_network_bytes. */
int64_t vdbs_inet_voxel_bytes(size_t voxels);
/* The bytes of a network of `particles` on `directions` and its solve: per particle its
 * position and voxel, per slot (particle and direction) its upstream link, its emission and
 * the sweep's state (twice on the C path: the runner's copy), and the D x D phase. */
int64_t vdbs_inet_network_bytes(int64_t particles, int directions);

vdbs_status vdbs_inet_begin(const vdbs_solve *s, const vdbs_inet_desc *desc, vdbs_inet_run **run,
                            vdbs_error *err);
void vdbs_inet_light_depth(void *run, int light, const float *depth);
vdbs_status vdbs_inet_finish(vdbs_inet_run *run, vdbs_inet_stats *stats, vdbs_error *err);
void vdbs_inet_end(vdbs_inet_run *run);

#ifdef __cplusplus
}
#endif

#endif
