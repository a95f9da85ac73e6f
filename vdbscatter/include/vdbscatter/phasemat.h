/* The discrete phase matrix of a discrete-ordinates solver and its factorisation (Gong et al.,
 * docs/methods/svd.md; `--method svd`, `vdbscatter phase-svd`).
 *
 * D directions w_i spread evenly over the sphere (the spherical Fibonacci lattice of
 * lights.h, each with the solid angle 4 pi / D). With docs/design.md's normalised HG,
 * integral p(w . w') dw = 1, the matrix
 *   P_ij = s_i p(w_i . w_j) (4 pi / D) s_j
 * is the probability that light travelling along w_j scatters into w_i: symmetric, and the
 * diagonal scaling s (a symmetric Sinkhorn balance) makes every row and column sum to 1
 * exactly, so a scattering event keeps its energy in the discrete problem too (the plain
 * quadrature sums are off by up to tens of percent where the peak is narrow).
 *
 * Delta-M (Wiscombe 1977): where the forward peak is narrower than the directions can resolve
 * (the quadrature's row sums of the unscaled matrix off by more than 1%), the fraction
 * f = g^M of the scattering, M = floor(sqrt(D)) the Legendre order D directions resolve, is
 * moved into the unscattered beam and the rest is an HG of g* = (g - f) / (1 - f): the solver
 * then uses sigma_t* = sigma_t - f sigma_s and sigma_s* = (1 - f) sigma_s.
 *
 * The factorisation: P = U diag(lambda) U^T (LAPACKE dsyevd; P is symmetric), terms kept in
 * order of |lambda| (a negative g has negative modes); the N-term matrix is
 * P_N = sum_{k<N} lambda_k u_k u_k^T, its relative RMSE ||P - P_N||_F / ||P||_F =
 * sqrt(sum_{k>=N} lambda_k^2 / sum_k lambda_k^2), which never rises with N. */
#ifndef VDBSCATTER_PHASEMAT_H
#define VDBSCATTER_PHASEMAT_H

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The relative error of the quadrature's row sums beyond which delta-M scaling is used. */
#define VDBS_PHASEMAT_DELTA_M_TOLERANCE 0.01
/* Most directions (a D x D matrix of doubles: 2 GiB at this size). */
#define VDBS_PHASEMAT_MAX_DIRECTIONS 16384

/* Zero-initialise. */
typedef struct vdbs_phasemat_desc {
    int directions; /* D >= 2 */
    double g;       /* HG anisotropy, |g| < 1 */
    int delta_m;    /* 0: when the quadrature cannot resolve the peak (above); 1: always;
                       -1: never */
} vdbs_phasemat_desc;

typedef struct vdbs_phasemat {
    int d;
    double g;                /* the medium's */
    double f;                /* delta-M peak fraction moved into the beam (0 without) */
    double g_scaled;         /* HG anisotropy of the truncated phase (g without delta-M) */
    double quadrature_error; /* largest |row sum - 1| of the unscaled, unbalanced matrix */
    double *dirs;            /* 3 D unit directions */
    double *p;               /* D x D, row-major: P_ij */
    double *eigval;          /* D eigenvalues, |lambda| descending */
    double *eigvec;          /* D x D, column k (eigvec[i D + k]) the unit eigenvector k */
} vdbs_phasemat;

/* Builds and factorises the matrix. Errors: D outside [2, VDBS_PHASEMAT_MAX_DIRECTIONS], g not
 * in (-1, 1) or not finite (VDBS_ERR_INPUT), out of memory, a failed eigensolve. */
vdbs_status vdbs_phasemat_build(const vdbs_phasemat_desc *desc, vdbs_phasemat *m, vdbs_error *err);
void vdbs_phasemat_free(vdbs_phasemat *m);

/* Relative RMSE of the N-term factorisation (0 <= N <= D). */
double vdbs_phasemat_rmse(const vdbs_phasemat *m, int terms);

/* Entry (i, j) of the N-term matrix. */
double vdbs_phasemat_entry(const vdbs_phasemat *m, int terms, int i, int j);

#ifdef __cplusplus
}
#endif

#endif
