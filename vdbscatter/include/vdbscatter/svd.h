/* Discrete ordinates with an SVD-factored phase (Gong and Ren, docs/methods/svd.md;
 * `--method svd`): the multiply-scattered light as the solution of the transport equation on D
 * directions (phasemat.h: balanced phase matrix, delta-M, factorisation) over a world-aligned
 * grid of cubic cells on the support box, by source iteration. Each iteration sweeps every
 * direction upwind in dependency order through the kernel runner (shaders/vs_svd.h,
 * svd_sweep.comp); the in-scattered source comes from N moments per cell,
 * m_k = sum_d v_k(w_d) L_d, as sum_k v_k(w) lambda_k sigma_s* m_k, so that memory and the cost
 * of the source grow with N, not D. N = D is the exact-phase baseline.
 *
 * The scene's light enters as its first scattering, from the unscattered light of the exact
 * S1 pass's light grids: per cell and sun or point light the power it scatters, emitted by
 * HG(g*) exactly per direction; the sky ordinates' the same, projected on the v_k once. With
 * delta-M (peak fraction f), the solver works on the scaled problem: the beam attenuates with
 * sigma_t* = sigma_t - f sigma_s, scatters with sigma_s* = (1 - f) sigma_s and the truncated
 * phase; ms and ms_l1 are that problem's scattered field plus the light its beam carries
 * after scattering only into the forward peak (docs/methods/svd.md, "Delta-M"), while S1 stays
 * the exact pass's. */
#ifndef VDBSCATTER_SVD_H
#define VDBSCATTER_SVD_H

#include <stdint.h>

#include "vdbscatter/runner.h"
#include "vdbscatter/phasemat.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/solve.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Zero-initialise; 0 means the default. */
/* The sweep's cell scheme (shaders/vs_svd.h). */
typedef enum vdbs_svd_scheme {
    VDBS_SVD_STEP = 0, /* every outflow face carries the cell's mean */
    VDBS_SVD_DIAMOND   /* each axis's outflow extrapolated with the slab weight of its depth */
} vdbs_svd_scheme;

typedef struct vdbs_svd_desc {
    int directions;         /* D (--svd-directions); default: the quality's */
    int terms;              /* N (--svd-terms), at most D; default: the fewest whose factorisation
                               RMSE is within the quality's tolerance */
    int resolution;         /* cells across the support box's extent (--svd-res); default: the
                               quality's; never finer than the voxels */
    int across;             /* cells at least across every axis (--svd-across; coarse.h's
                               vdbs_coarse_world_frame); default the quality's, 1: cubic
                               cells */
    double residual;        /* stop once the fluence's estimated relative distance from the
                               converged one is at most this (--residual): the last iteration's
                               relative change, times rho / (1 - rho) where the contraction rho
                               (stats) exceeds 1/2; default: the quality's. The fluence and flux
                               (and kept moments) are then extrapolated along that tail
                               (stats.extrapolated), which lands them far closer than this */
    int last_sweep;         /* 1: the outputs are the last sweep's, not extrapolated (studies of
                               the iteration itself); default 0 */
    int max_iterations;     /* the cap (--svd-iterations); default 2000; a solve whose
                               settled contraction predicts more stops early, not converged */
    int delta_m;            /* phasemat.h: 0 auto, 1 always, -1 never */
    vdbs_svd_scheme scheme; /* --svd-scheme; default the step */
    int sky_boundary;       /* 1: the sky's uniform part enters through the grid's boundary
                               (--svd-sky boundary, skyfloor.h); 0: the whole sky as first
                               collisions */
    int chunk;              /* directions per sweep step; default: an octant's on the C path, as
                               many as keep a step under the GPU driver's loop limit on the GPU */
    const struct vdbs_svd_moments *warm; /* --warm-start: moments to start from, or NULL;
                                            its D and N unless directions or terms are set
                                            (then they must match) */
    struct vdbs_svd_moments *keep;       /* --keep-state: filled with the final moments
                                            (extrapolated as the fluence), or NULL */
    vdbs_progress *progress;             /* the iterations, as the residual's way from 1 to
                                            `residual` on a log scale; may be NULL */
} vdbs_svd_desc;

/* The radiance moments m_k at the output voxels, for --keep-state and --warm-start (the lit
 * VDB's svd_m* grids): sampled trilinearly from the cells, and back, each cell the mean over
 * the voxels whose centres lie in it. */
typedef struct vdbs_svd_moments {
    int directions; /* D */
    int terms;      /* N */
    double g;       /* the medium's g they were solved for */
    float **voxels; /* N arrays of 3 floats per output voxel (coords order) */
    /* The contraction (ratio of successive changes) of the solve that made them when it
     * stopped; 0: unknown. A warm start's error estimate needs it (vdbs_svd_grid). */
    double contraction;
} vdbs_svd_moments;

/* Allocates N zeroed arrays for `voxels` output voxels. Errors: out of memory. */
vdbs_status vdbs_svd_moments_alloc(vdbs_svd_moments *m, int directions, int terms, double g,
                                   size_t voxels, vdbs_error *err);
void vdbs_svd_moments_free(vdbs_svd_moments *m);
/* Whether a warm start fits a solve asking for D directions and N terms (0: any) with the
 * medium's g. Errors (VDBS_ERR_INPUT) name --warm-start. */
vdbs_status vdbs_svd_warm_check(const vdbs_svd_moments *warm, int directions, int terms, double g,
                                vdbs_error *err);

/* What each quality chooses, low to ultra: one list per field, read by vdbs_svd_quality and
 * by the solver entry's option presets (so --help's defaults and the solve's agree). */
#define VDBS_SVD_PRESET_DIRECTIONS 32, 64, 128, 512
#define VDBS_SVD_PRESET_RESOLUTION 16, 24, 32, 32
#define VDBS_SVD_PRESET_ACROSS 8, 8, 12, 12
#define VDBS_SVD_PRESET_TOLERANCE 0.10, 0.05, 0.02, 0.01
#define VDBS_SVD_PRESET_RESIDUAL 3e-2, 3e-2, 1e-2, 3e-3

/* What a quality chooses. */
typedef struct vdbs_svd_preset {
    int directions;   /* D */
    int resolution;   /* cells across the largest extent */
    int across;       /* cells at least across every axis */
    double tolerance; /* factorisation RMSE of the default N */
    double residual;  /* the stopping rule's (extrapolated after, svd_desc) */
} vdbs_svd_preset;

/* The preset of a quality name (medium's for an unknown one). */
void vdbs_svd_quality(const char *quality, vdbs_svd_preset *preset);

/* The fewest terms whose relative RMSE is at most tolerance (D when none is). */
int vdbs_svd_terms_for(const vdbs_phasemat *pm, double tolerance);

/* The moments per voxel a solve of desc at this quality keeps (vdbs_svd_begin's rule: the
 * warm start's, the terms asked for, or the fewest within the quality's tolerance), before
 * it runs: for the bake's memory estimate. 0 when the phase matrix cannot be built. */
int vdbs_svd_kept_terms(const vdbs_svd_desc *desc, const char *quality, double g);

/* The bytes a solve holds per output voxel (the faces, one light's first collisions and
 * their scratch) for `voxels` of them; its cells are bounded by the grid's resolution and not
 * counted. For the bake's memory estimate. */
int64_t vdbs_svd_voxel_bytes(size_t voxels);

/* A direct light of a grid problem. */
typedef struct vdbs_svd_light {
    int point; /* 1: a point light at vec; 0: a sun travelling along vec (unit) */
    double vec[3];
} vdbs_svd_light;

/* One problem on a grid of n[0] x n[1] x n[2] box cells of sides h[0], h[1], h[2] along x, y,
 * z from `origin` (world), item (k n1 + j) n0 + i. */
typedef struct vdbs_svd_grid {
    int n[3];
    double h[3];
    double origin[3];
    const float *sigma_t; /* per cell (the unscaled medium) */
    double albedo[3];
    const vdbs_phasemat *phase; /* D directions, f, g*, the factorisation */
    int terms;                  /* N */
    const vdbs_svd_light *lights;
    int light_count;
    const float *direct; /* per cell and light, 3 channels: the power per volume its
                            unscattered light scatters there in the scaled problem, divided by
                            the discrete normalisation sum_d HG(g*, travel . w_d) dw_d */
    const float *sky;    /* per cell, N x 3 (laid out by vs_svd_moment_at, shaders/vs_svd.h):
                            the sky's first scattering projected on the v_k (power per volume
                            and steradian), or NULL */
    const float *warm;   /* per cell, N x 3 the same way: the radiance moments to start from,
                            or NULL */
    double inflow[3];    /* the radiance entering every boundary face from outside in every
                            direction (the sky's uniform part, skyfloor.h); 0: vacuum */
    /* With warm: the contraction of the solve it came from (0: unknown). The error estimate
     * uses the larger of it and the ratio seen so far: started near the answer, the first
     * few changes shrink with the faster modes and understate the slowest one, which the
     * last frame's solve measured. */
    double warm_contraction;
} vdbs_svd_grid;

typedef struct vdbs_svd_stats {
    int directions, terms, resolution;
    int64_t cells;
    double cell_side;
    double delta_m_f, g_scaled; /* 0 and g without delta-M */
    double factor_rmse;         /* of the N-term factorisation */
    int chunk, steps_per_sweep;
    int warm_start; /* 1: the iteration started from a --warm-start's moments */
    int iterations;
    double residual;    /* the estimated relative distance from the converged fluence (desc) */
    double contraction; /* the mean ratio of successive changes over the last 4 iterations:
                           the error's shrink per iteration */
    int predicted_iterations; /* what the contraction says reaching `residual` takes in all */
    int converged; /* 0: stopped at the cap, or before it where predicted_iterations exceeds it */
    double extrapolated; /* rho / (1 - rho): the fluence, flux and kept moments were
                            extrapolated along the geometric tail by this times the last
                            change (0: not) */
    /* The last sweep's power balance (summed over channels, in double from per-cell float
     * tallies): emitted = collided + leaked up to `balance`, the worst relative mismatch
     * |emitted - collided - leaked| / emitted over every sweep. */
    double emitted, collided, leaked, clamped, balance;
    double clamped_fraction; /* clamped / (emitted + clamped), worst over the sweeps */
    double first_power;      /* the first scattering's power (direct and sky) */
    int64_t cell_direction_updates;
    double seconds_source, seconds_solve, seconds_upsample;
} vdbs_svd_stats;

/* Source iteration on the grid: fluence (3 per cell, sum_d L_d dw_d), flux (9 per cell, the
 * x, y, z components of R, G, B of sum_d L_d w_d dw_d) and the final radiance moments (N x 3
 * per cell, as `sky`) out, each may be NULL. stats may be NULL. Errors: out of memory, the
 * runner's. */
vdbs_status vdbs_svd_solve_grid(vdbs_runner *runner, const vdbs_svd_grid *grid,
                                const vdbs_svd_desc *desc, double *fluence, double *flux,
                                float *moments, vdbs_svd_stats *stats, vdbs_error *err);

/* The bake's solver, in three steps around the S1 pass so that the pass's light grids serve
 * both: vdbs_svd_begin (the phase matrix, the grid, the medium; checks a warm start), the
 * S1 pass with vdbs_svd_light_depth as its vdbs_s1_outputs.light_depth (every light's first
 * scattering into the cells), then vdbs_svd_finish (the iteration; adds ms and ms_l1 to
 * s->ms, s->ms_l1 and s->radiance) and vdbs_svd_end. stats may be NULL. */
typedef struct vdbs_svd_run vdbs_svd_run;
vdbs_status vdbs_svd_begin(const vdbs_solve *s, const vdbs_svd_desc *desc, vdbs_svd_run **run,
                           vdbs_error *err);
void vdbs_svd_light_depth(void *run, int light, const float *depth);
vdbs_status vdbs_svd_finish(vdbs_svd_run *run, vdbs_svd_stats *stats, vdbs_error *err);
void vdbs_svd_end(vdbs_svd_run *run);

#ifdef __cplusplus
}
#endif

#endif
