/* The participating medium of a density volume (docs/design.md "Physical conventions"):
 * sigma_t(x) = density(x) * density_scale per world unit, sigma_s = sigma_t * albedo (RGB),
 * sigma_a = sigma_t - sigma_s, and a Henyey-Greenstein phase of anisotropy g
 * (shaders/vs_phase.h). Also the majorant grid that tracking estimators (the Monte-Carlo
 * reference) sample collisions against, and a DDA that walks it along a ray.
 *
 * Rays here are index-space rays x(t) = o + t d, with d the index image of a unit world
 * step, so t is measured in world units and majorants are per world unit. */
#ifndef VDBSCATTER_MEDIUM_H
#define VDBSCATTER_MEDIUM_H

#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_medium {
    const vdbs_volume *volume; /* not owned; must outlive the medium */
    double density_scale;      /* sigma_t = density * density_scale */
    double albedo[3];          /* sigma_s / sigma_t per RGB channel */
    double g;                  /* HG anisotropy */
} vdbs_medium;

/* The medium of `volume` with the scene's density_scale, albedo and g, taken as they are
 * (vdbs_scene_validate checks their ranges). */
void vdbs_medium_init(vdbs_medium *medium, const vdbs_volume *volume, const vdbs_scene *scene);

/* sigma_t at an index-space point: the float trilinear interpolant of the density (the
 * point rounded to float, as every march reads it) times density_scale. Builds a fresh
 * NanoVDB accessor per call: for tests and one-off queries, not for inner loops. */
double vdbs_medium_sigma_t(const vdbs_medium *medium, const double index_point[3]);

/* Upper bounds of sigma_t over blocks of `block`^3 voxels covering the index-space support
 * box (vdbs_volume_support_box). A voxel contributes its density to every cell that meets
 * the open box of side 2 around it, where the trilinear interpolant depends on it, so
 * maj >= sigma_t everywhere in a cell (grown by 1e-5 relative for the float interpolant's
 * rounding). `block` starts at 4 voxels (4 beat 8, a NanoVDB leaf, by 15-25% on the
 * Disney cloud and the OpenVDB smoke: fewer null collisions near edges) and doubles until
 * the grid has at most VDBS_MAJORANT_MAX_CELLS cells. */
#define VDBS_MAJORANT_BLOCK 4
#define VDBS_MAJORANT_MAX_CELLS (1 << 24)

typedef struct vdbs_majorant_grid {
    int dims[3];         /* cells per axis */
    int block;           /* voxels per cell edge */
    double lo[3], hi[3]; /* index-space support box; cell (0,0,0) starts at lo */
    float *maj;          /* dims[0] * dims[1] * dims[2] bounds, x fastest; owned */
} vdbs_majorant_grid;

/* Builds the grid of `medium` (all zero when density_scale <= 0). Errors: out of memory
 * (VDBS_ERR_NOMEM). On error the grid holds nothing to free. */
vdbs_status vdbs_majorant_grid_build(const vdbs_medium *medium, vdbs_majorant_grid *grid,
                                     vdbs_error *err);

void vdbs_majorant_grid_free(vdbs_majorant_grid *grid);

/* Clips the ray o + t d, t in [0, tmax], to the grid's support box: [*t0, *t1]. Returns 0
 * when they do not meet (t0 >= t1). *exit_axis is the index axis of the face through which
 * the unclipped ray leaves the box (-1 when d = 0). */
int vdbs_majorant_grid_clip(const vdbs_majorant_grid *grid, const double o[3], const double d[3],
                            double tmax, double *t0, double *t1, int *exit_axis);

/* Walks the cells of a grid along a clipped ray segment [t0, t1] in order. Consecutive
 * segments share their end points exactly (the first starts at t0); the last ends at t1
 * unless rounding takes the ray out of the grid's cells a hair earlier. */
typedef struct vdbs_majorant_dda {
    const vdbs_majorant_grid *grid;
    int cell[3];
    int step[3];
    double next[3];  /* ray parameter of the next cell plane per axis */
    double delta[3]; /* ray parameter between cell planes per axis */
    double t, t_end;
} vdbs_majorant_dda;

void vdbs_majorant_dda_init(vdbs_majorant_dda *dda, const vdbs_majorant_grid *grid,
                            const double o[3], const double d[3], double t0, double t1);

/* The next segment [*ta, *tb] and its majorant *maj (per world unit); returns 0 when the
 * segment is done. Segments may be empty (ta = tb) where the ray crosses a cell edge. */
int vdbs_majorant_dda_next(vdbs_majorant_dda *dda, double *ta, double *tb, double *maj);

/* The density box-filtered onto blocks of `block`^3 voxels (index space), for solvers that
 * work on grids coarser than the voxels (POP Sec. 4.2: "the medium parameters need to be
 * sampled from a downscaled version of the volume"). Cell (i, j, k) holds the mean voxel
 * value of the block whose first voxel is lo + block (i, j, k) (inactive voxels count 0);
 * its centre is at index lo + block (i + 1/2) - 1/2. */
typedef struct vdbs_medium_box {
    int lo[3];
    int dims[3];
    int block;
    float *density; /* dims[0] * dims[1] * dims[2], x fastest; owned */
} vdbs_medium_box;

/* Errors: block < 1 (VDBS_ERR_INPUT), out of memory. */
/* The mean density over the output voxels whose density is > 0 (0 if none): what the
 * solvers scale their grids and decay laws from. */
double vdbs_medium_mean_density(const vdbs_volume *volume);

vdbs_status vdbs_medium_box_build(const vdbs_volume *volume, int block, vdbs_medium_box *box,
                                  vdbs_error *err);
void vdbs_medium_box_free(vdbs_medium_box *box);
/* The box-filtered density at an index-space point: trilinear between cell centres, 0 beyond
 * the outermost cells' centres by one cell (the same ramp as the voxels'). */
double vdbs_medium_box_density(const vdbs_medium_box *box, const double index[3]);

/* Entries (4 floats each) of the kernels' medium table (shaders/vs_medium.h). */
#define VDBS_MEDIUM_TABLE_ENTRIES 10

/* The kernels' medium table: density scale, g, albedo, the volume's map both ways and its
 * support box. */
void vdbs_medium_pack(const vdbs_medium *medium, float table[4 * VDBS_MEDIUM_TABLE_ENTRIES]);

#ifdef __cplusplus
}
#endif

#endif
