/* Flux-limited diffusion (Koerner, Portsmouth, Sadlo, Ertl, Eberhardt 2014): multiple
 * scattering as the steady diffusion of the first-scattered light,
 *   -div(D grad phi) + sigma_a phi = Q,   D = lambda(R) / sigma_tr,
 * with the reduced coefficient sigma_tr = sigma_a + sigma_s (1 - g) and the Levermore-Pomraning
 * limiter lambda(R) = (2 + R) / (6 + 3 R + R^2), R = |grad phi| / (sigma_tr phi), on a
 * world-aligned grid of cubic cells over the support box (coarse.h). Cell-centred finite
 * volumes, face coefficients by harmonic mean, a Marshak vacuum condition at the boundary;
 * each channel's symmetric system is solved by conjugate gradients preconditioned with a
 * multigrid V-cycle (cells aggregated 2 x 2 x 2 per level, damped Jacobi smoothing), whose
 * operator on every level runs through the kernel runner (shaders/vs_fld.h, fld_apply.comp),
 * the limiter updated between solves. Q is the light scattered for the first time, sigma_s times
 * the S1 pass's fluence at every voxel, gathered into the cells, with its first moment g sigma_s
 * times the S1 pass's net flux (the P1 source: forward-peaked light keeps going forward);
 * ms = phi / 4 pi. */
#ifndef VDBSCATTER_FLD_H
#define VDBSCATTER_FLD_H

#include <stdint.h>

#include "vdbscatter/runner.h"
#include "vdbscatter/skyfloor.h"
#include "vdbscatter/solve.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The solved fluence phi at the output voxels, trilinear from the cells: what --keep-state
 * writes into the lit VDB (grid fld_phi, metadata vdbscatter_fld_state = "phi") and
 * --warm-start reads back (the cells whose trilinear samples give it, by back-projection from
 * the voxels the file has a value for; cells no such voxel weighs filled from their
 * neighbours: fld.c's phi_from_voxels). */
typedef struct vdbs_fld_state {
    float *phi; /* 3 floats (R, G, B) per output voxel, coords order; NULL until solved */
    size_t voxels;
} vdbs_fld_state;

/* Zero-initialise; 0 means the default. */
typedef struct vdbs_fld_desc {
    int resolution;   /* cells across the largest extent (--fld-res); default: from the
                         medium per the quality (vdbs_fld_preset); never finer than the
                         voxels */
    int across;       /* cells at least across every axis (--fld-across; coarse.h's
                         vdbs_coarse_world_frame); default VDBS_COARSE_MIN_ACROSS, 1: cubic
                         cells */
    int limiter_off;  /* 1: classic diffusion, D = 1 / (3 sigma_tr); with the limiter or
                         without, D is capped at (the grid's largest extent) / 3, the D of a
                         medium one transport mean free path across the grid (empty cells) */
    int max_updates;  /* solves with the limiter updated in between; default 6 */
    double tolerance; /* relative residual |b - A phi| / |b| of every solve; default: the
                         quality's */
    int write_l1;     /* 1: ms_l1 from the flux, (3 g / 4 pi) F (vdbs_fld_solve_grid); the
                         bake sets it unless --fld-l1 off (bench/fld.md measures both) */
    int runner_cells; /* multigrid levels with fewer cells apply the operator in a host loop
                         (the same vs_fld.h text): a dispatch costs more than their work;
                         default 4096, 1: every level through the runner (the twin test) */
    /* The bake's first collisions (collision.h's sums over the lights, per output voxel):
     * `collisions` 3 per voxel, the cube average of sigma_t E T, from which the source
     * albedo collisions comes; `collision_flux` 9 per voxel, the same times each light's
     * travel, from which the first-moment source g albedo collision_flux comes (NULL: an
     * isotropic source, --fld-p1 off or g = 0). */
    const double *collisions;
    const double *collision_flux;
    /* The sky's uniform part through the grid's boundary (--fld-sky boundary; skyfloor.h):
     * its radiance L enters each boundary face as the inward current pi L (Marshak's
     * condition, vdbs_fld_grid.inflow) instead of as first collisions (`collisions` holds the
     * ordinates' remainder only), and its unscattered light is taken off ms after the solve.
     * NULL: the whole sky enters as first collisions. */
    const vdbs_sky_floor *sky_floor;
    const vdbs_cancel *cancel; /* polled every CG iteration: VDBS_ERR_CANCELLED once set;
                                  NULL: never (the bake's is its progress's) */
    /* --warm-start (vdbs_fld_solve): phi to start from, the first solve's first guess and the
     * first limiter's phi, or NULL (a cold start: classic diffusion first). */
    const vdbs_fld_state *warm;
    /* --keep-state (vdbs_fld_solve): filled with the solved phi (phi malloc'd here, the
     * caller frees it), or NULL. */
    vdbs_fld_state *keep;
} vdbs_fld_desc;

/* What a quality chooses. The grid comes from the medium: cells_per_path cells per mean
 * transport free path 1 / sigma_tr (the mean over voxels with density) across the largest
 * extent, at least min_resolution, never finer than the voxels. */
typedef struct vdbs_fld_preset {
    /* 1 and 12 at every quality: finer grids converge to FLD's own diffusion bias and
     * measured worse (docs/planner.md, "Ladders"); the ladder spends on S1 instead */
    double cells_per_path;
    int min_resolution;
    double tolerance; /* 1e-4 / 1e-5 / 1e-6 / 1e-7 */
} vdbs_fld_preset;

/* The preset of a quality name (medium's for an unknown one). */
void vdbs_fld_quality(const char *quality, vdbs_fld_preset *preset);

/* A medium on a grid of n[0] x n[1] x n[2] box cells of sides h[0], h[1], h[2] along x, y, z
 * (item (k n1 + j) n0 + i). */
typedef struct vdbs_fld_grid {
    int n[3];
    double h[3];
    const float *sigma_t; /* per cell */
    double albedo[3];
    double g;
    const double *source; /* Q per cell and channel (3 per cell): power per volume */
    const double *moment; /* M, the source's first moment (9 per cell: x, y, z of R, G, B;
                             g Q d for light first scattered from direction of travel d), or
                             NULL. It enters Fick's law as F = -D grad phi + 3 D M (the P1
                             source, M / sigma_tr without the limiter), so the system's right
                             side gains -div(3 D M), and a boundary face leaks its part */
    const double *inflow; /* per boundary face of the box (-x, +x, -y, +y, -z, +z) and channel
                             (18): the inward partial current J of light arriving from outside,
                             power per area, entering by Marshak's condition
                             phi / 4 + (D / 2) d phi / dn = J; NULL: none (vacuum) */
} vdbs_fld_grid;

typedef struct vdbs_fld_stats {
    int resolution;       /* cells across the largest extent */
    double mean_sigma_tr; /* what a default resolution came from (0 with --fld-res) */
    int64_t cells;
    double cell_side;
    int warm_start;            /* 1: the first solve started from a given phi (a warm start
                                  that covered any cell), its limiter from that phi */
    int updates;               /* solves run (limiter updates + 1) */
    int cg_iterations;         /* summed over channels and solves */
    int levels;                /* of the multigrid preconditioner, the system's own grid included */
    int operator_applications; /* of the operator kernel on every level, summed */
    int64_t cell_updates;      /* cells those applications updated (one channel each) */
    double residual;           /* the last solve's relative residual, worst channel, in double */
    /* Power summed over the channels: source sum Q V, absorbed sum sigma_a phi V, leaked
     * through the boundary (Marshak, with the first-moment source's share at the boundary
     * faces), all from phi in double. */
    double source, absorbed, leaked;
    double seconds_source, seconds_solve, seconds_upsample;
} vdbs_fld_stats;

/* Solves the grid's system: phi (3 per cell) in and out (in: the first guess, 0 if unknown);
 * flux (9 per cell: x, y, z components of the R, G, B flux -D grad phi + 3 D M, shortened to
 * at most phi / 3, P1's realizable bound) may be NULL.
 * stats may be NULL. Errors: out of memory, the runner's. */
vdbs_status vdbs_fld_solve_grid(vdbs_runner *runner, const vdbs_fld_grid *grid,
                                const vdbs_fld_desc *desc, double *phi, double *flux,
                                vdbs_fld_stats *stats, vdbs_error *err);

/* One application y = A x of the operator (shaders/vs_fld.h) on the runner, for the twin
 * tests; *xax = x . A x (the kernel's reduction). */
vdbs_status vdbs_fld_operator(vdbs_runner *runner, const uint32_t *params, const float *coef,
                              int64_t cells, const float *x, float *y, double *xax,
                              vdbs_error *err);

/* The bake's FLD: after the S1 pass (s->radiance holds S1), adds ms (and with write_l1 the
 * moments) to s->ms, s->ms_l1 and s->radiance. stats may be NULL. */
vdbs_status vdbs_fld_solve(const vdbs_solve *s, const vdbs_fld_desc *desc, vdbs_fld_stats *stats,
                           vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
