/* Principal-Ordinates Propagation (Elek et al. 2014, Secs. 3-6) for suns,
 * the constant sky, lat-long maps and point lights. Multiple scattering only (the
 * exact S1 pass owns unscattered light, docs/design.md): every sun and POP sky ordinate gets a
 * coarse directional grid seeded with the light first scattered in each cell (from the fine S1
 * light grid: per sub-column albedo E (T_in - T_out)), propagated cell by cell (the shared
 * kernel shaders/vs_pop.h) until its anisotropy has decayed below epsilon_a (Eq. 10), then the
 * residual of every grid is merged into one world-aligned grid of the same cell side and
 * propagated isotropically until the energy left is below epsilon_L of the seeded energy.
 * A cell crossing deposits the fluence of the lobe's mean chord (--pop-tally chord; the paper
 * counts a whole side). Each grid's accumulated lobes map onto ms and ms_l1 exactly (HG
 * self-convolution), are splatted into a world-aligned grid at twice the resolution (conserving
 * energy) and upsampled to the voxels by a joint bilateral filter guided by the density.
 *
 * A point light gets a radial grid instead (Sec. 6, vdbscatter/radial.h): octahedral texels
 * times shells growing geometrically from the light, seeded from its fine radial S1 grid with
 * anisotropy g about the radial direction, propagated by the same gather (the lobe's power
 * L A(cell) is what moves between cells of unequal size: shaders/vs_pop.h), then merged
 * part by part into the merged grid, whose cells are then extent / radial wide. */
#ifndef VDBSCATTER_POP_H
#define VDBSCATTER_POP_H

#include "vdbscatter/pop_engine.h"
#include "vdbscatter/radial.h"
#include "vdbscatter/solve.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Zero-initialise; 0 means the default. */
typedef struct vdbs_pop_desc {
    int resolution; /* cells across the largest extent of the support box (--pop-res);
                       default 4, the measured best (pop.c, bench/pop.md) */
    int ordinates;  /* POP sky ordinates (--pop-ordinates); default: the quality's */
    int radial;     /* a point light's radial grid: radial x radial octahedral texels times
                       radial shells (--pop-radial, even); default: the quality's */
    vdbs_pop_decay decay;
    int tally_cell;     /* 1: a crossing deposits the fluence of one cell side (the paper's);
                           0: of the lobe's mean chord (shaders/vs_pop.h vs_pop_chord) */
    int importance;     /* 1: sample the sky ordinates from the sky times the camera's
                           importance (Sec. 5.2; needs the scene's camera) */
    int max_iterations; /* cap of the anisotropic stage per grid; default 4 x resolution,
                           at least 64 */
    double epsilon_a;   /* anisotropy below which a grid goes isotropic; default 0.1 */
    double epsilon_l;   /* energy left, relative to the seeded energy, that stops; default:
                           the quality's */
} vdbs_pop_desc;

/* The defaults of a quality name ("low" ... "ultra"): sky ordinates 8 / 16 / 32 / 64,
 * epsilon_L 1e-2 / 1e-3 / 1e-4 / 1e-5 and radial grids of 8^3 / 16^3 / 32^3 / 64^3 (the
 * resolution keeps its default of 4 cells at every quality: bench/pop.md). radial may be
 * NULL. */
void vdbs_pop_quality(const char *quality, int *ordinates, double *epsilon_l, int *radial);

typedef struct vdbs_pop_stats {
    int grids;                  /* directional grids: suns + sky ordinates */
    int radial_grids;           /* radial grids: point lights */
    int radial;                 /* their texels across and shells */
    int importance;             /* 1: the ordinates were sampled with the camera's importance */
    long long importance_cells; /* of its frustum grid */
    int importance_iterations;
    int resolution;             /* cells across the largest extent */
    long long cells;            /* cells of all directional and radial grids */
    long long merged_cells;     /* cells of the merged grid (half the cell side) */
    int iterations_anisotropic; /* the most any directional grid ran */
    int iterations_isotropic;
    double cell_updates; /* cells x iterations over every grid, directional and isotropic */
    double cell_side;    /* world side of a directional grid's cell */
    double seeded;       /* energy seeded (sum over cells and channels of L^0 times cell volume) */
    /* The same sum from each sub-column's whole loss, albedo E (1 - T) (pop.c seed_grid):
     * equal to seeded when every grid holds all of the medium. */
    double beam_loss;
    double residual; /* energy left in transit at the end, relative to seeded */
    /* The merge's balance: accumulated fluence times cell volume summed over the directional
     * grids' cells, and over the merged grid's after the splat (equal up to rounding). */
    double merge_in, merge_out;
    /* Stage times: sweep (the fine S1 grids of the POP lights, for seeding), seed (sigma per
     * cell and the seed), propagate (directional grids), isotropic, merge, upsample. */
    double seconds_sweep, seconds_seed, seconds_propagate, seconds_isotropic, seconds_merge,
        seconds_upsample;
    double seconds_importance; /* the importance grid's propagation and projection */
} vdbs_pop_stats;

/* What desc asks of the scene, checked before any work: an odd radial resolution,
 * --pop-decay paper with g < 0, --pop-importance without a camera (VDBS_ERR_INPUT). */
vdbs_status vdbs_pop_check(const vdbs_pop_desc *desc, const vdbs_scene *scene, vdbs_error *err);

/* Adds POP's ms and ms_l1 to the solve's outputs (and ms to radiance); S1 is the caller's.
 * Errors: --pop-decay paper with g < 0, an odd radial resolution (VDBS_ERR_INPUT), out of
 * memory, GPU errors. */
vdbs_status vdbs_pop_solve(const vdbs_solve *solve, const vdbs_pop_desc *desc,
                           vdbs_pop_stats *stats, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
