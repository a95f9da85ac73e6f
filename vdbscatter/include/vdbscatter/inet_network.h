/* The particles and the visibility network of the illumination-network solver
 * (Szirmay-Kalos et al., docs/methods/inet.md; `--method inet`), built once per volume.
 *
 * Particles: N points sampled in proportion to the optical mass of each output voxel's cube,
 * the integral of the trilinear sigma_t the renderer and the light grids see (the centre's
 * value weighs 3/4 per axis, each face neighbour's 1/8, so the dilated ring of output voxels
 * past the last active centres holds the ramp's medium), stratified (the k-th at cumulative
 * mass (k + xi_k) / N, xi_k from a seeded stream), each uniformly placed inside the voxel it
 * fell in; every particle carries the same optical mass m = (total mass) / N.
 *
 * The network: for each of D directions of travel w_d, the particles projected orthographically
 * onto a window of M x M pixels that covers the particles' bounding sphere (side 2R,
 * perpendicular to w_d) and ordered by depth along w_d in each pixel (a bucket sort, the
 * paper's depth peeling on the C path). Each particle's upstream neighbour for w_d is the one
 * before it in its pixel: the particle whose outgoing light along w_d reaches it. The pixel's
 * area A = (2R / M)^2 is every particle's cross-section: its optical thickness is m / A, the
 * same in every direction, so that a column of pixel area through the particles holds on
 * average the optical depth of the medium along it. */
#ifndef VDBSCATTER_INET_NETWORK_H
#define VDBSCATTER_INET_NETWORK_H

#include <stdint.h>

#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Zero-initialise; 0 means the default. */
typedef struct vdbs_inet_network_desc {
    int64_t particles; /* N >= 1 (required) */
    int window;        /* M: pixels across the window; 0: vdbs_inet_window_rule */
    uint64_t seed;     /* of the particles' stream; 0 is a seed like any other */
} vdbs_inet_network_desc;

typedef struct vdbs_inet_network {
    int64_t particles; /* N */
    int directions;    /* D */
    int window;        /* M */
    int paper_window;  /* vdbs_inet_paper_window's bound, for the report */
    double centre[3];  /* the bounding sphere of the particles (world) */
    double radius;     /* R > 0 */
    double mass;       /* m: every particle's optical mass, sigma_t times volume (world^2) */
    double pixel_area; /* A = (2R / M)^2 (world^2) */
    float *position;   /* 3 N: world positions */
    int64_t *voxel;    /* N: the output voxel (coords index) each particle was sampled in */
    /* Per output voxel its cube's mean sigma_t (its optical mass over its volume): a
     * particle's share of its voxel's first collisions is m / (this times the volume). */
    float *voxel_sigma_t;
    /* N x D: upstream[p D + d], the particle just before p along direction d in p's pixel
     * (the light travelling along w_d reaches p from it), or -1 where p is first. */
    int32_t *upstream;
    const double *dirs; /* 3 D unit directions of travel: the caller's, not owned */
} vdbs_inet_network;

/* The paper's bound on the window, the largest M with D (R tau)^2 / pi >= M^2 (tau the mean
 * sigma_t over the active voxels: a particle's projected area should subtend at least a
 * direction's solid angle 4 pi / D from a free path away), in [1, 4096]. Reported, not used:
 * see vdbs_inet_window_rule. */
int vdbs_inet_paper_window(int directions, double radius, double mean_sigma_t);
/* The default window: M^2 = N / 4, about four particles to a pixel's column, in [1, 4096].
 * Measured on the cloud sample (docs/methods/inet.md, "The window"): the paper's bound, where
 * it is coarser, gives thin particles, long chains and many more Jacobi sweeps for the same
 * error (N 20000: M 52, 64 sweeps; M 70, 37 sweeps). */
int vdbs_inet_window_rule(int64_t particles);

/* The orthonormal basis (u, v) perpendicular to a unit direction of travel w that the window
 * is laid out in: a particle at p is at x = (p - centre) . u, y = (p - centre) . v, pixel
 * (floor((x + R) / (2 R) M), floor((y + R) / (2 R) M)) clamped to the window, row-major
 * (iy M + ix), at depth (p - centre) . w (smaller is upstream). Exposed for the tests'
 * brute-force oracle and the solver's gather. */
void vdbs_inet_basis(const double w[3], double u[3], double v[3]);

/* Samples the particles from the volume's density (times density_scale) and builds the network
 * for D directions `dirs` (3 D doubles, unit; kept by pointer). Deterministic for a seed
 * whatever the thread count. Errors: N < 1 or above INT32_MAX, D < 1, a volume without density
 * (VDBS_ERR_INPUT), out of memory. */
vdbs_status vdbs_inet_network_build(const vdbs_volume *volume, double density_scale,
                                    const double *dirs, int directions,
                                    const vdbs_inet_network_desc *desc, vdbs_inet_network *net,
                                    vdbs_error *err);
void vdbs_inet_network_free(vdbs_inet_network *net);

#ifdef __cplusplus
}
#endif

#endif
