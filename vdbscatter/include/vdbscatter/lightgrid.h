/* Light grids (docs/design.md "Light grids"): grids aligned with a light's transport, filled by one
 * transmittance sweep per column, so that the optical depth towards the light at any point
 * is a lookup instead of a march. Cost per light direction is linear in the cells.
 *
 * - directional grids (a sun, or one sky ordinate): an orthonormal frame (u, v, w), w the
 *   light's direction of travel, spanning the volume's support box; columns along w, h apart
 *   across and along (h = the smallest world voxel length / oversample). With an
 *   index-aligned direction, uniform voxels and an integer oversample, samples fall on voxel
 *   centres;
 * - radial grids (a point light; POP Sec. 6): octahedral directions times shells outwards
 *   from the light, the angular resolution chosen so that texels are at most about h wide at
 *   the support box's farthest corner (up to a cap); shells are h apart, or a texel's width
 *   where that is wider (exponential spacing, once the angular resolution is capped).
 *
 * A set of grids is one buffer of 32-bit words whose layout, sweep and lookup are written once
 * for C and GLSL in shaders/vs_lightgrid.h; the sweep and the lookup run through the kernel
 * runner on either backend. Columns that meet no density store nothing, and a column stores
 * only the stretch where its depth changes. The GPU sweeps in tiles of columns under the
 * driver's storage-buffer limit.
 *
 * Propagation solvers (POP) work on coarser instances of the same two kinds: the header
 * gives a grid's frame, shape (n0 x n1 columns of n2 samples), spacing or shells, so that a
 * solver keeps its per-cell state in arrays of its own indexed (column j n0 + i, sample k)
 * beside the set, and reads the swept depths through the same lookup. */
#ifndef VDBSCATTER_LIGHTGRID_H
#define VDBSCATTER_LIGHTGRID_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/runner.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The default oversampling: the smallest that keeps S1 within 1% relative RMSE of the exact
 * march on the bundled samples and the Disney cloud (tests/test_lightgrid.c). */
#define VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE 2

/* Sky ordinates' grids are sized to the sky's share of the light (docs/design.md "Light
 * grids", bench/s1.md): with s an ordinate's share of the light arriving at the volume (its
 * radiance times its solid angle, against every light's) times the number of ordinates (the
 * sky's share, were every ordinate like it), its grid is spaced
 * sqrt(VDBS_LIGHT_GRID_SKY_SHARE / s) smallest voxel lengths apart across and along its
 * columns, no finer than the suns' and no coarser than VDBS_LIGHT_GRID_SKY_MAX voxels. The
 * ordinates' interpolation errors add up rather than average out (measured: they grow as the
 * spacing squared times the sky's share), so the sky keeps the suns' spacing where it
 * carries most of the light; the constant keeps what coarsening adds under about 0.1%. */
#define VDBS_LIGHT_GRID_SKY_SHARE 0.12
#define VDBS_LIGHT_GRID_SKY_MAX 4.0

/* Zero-initialise; 0 means the default. */
typedef struct vdbs_light_grid_desc {
    int oversample; /* samples per smallest voxel length; default 2 */
    int bilinear;   /* 1: bilinear across the columns of directional grids (a quarter of the
                       memory traffic of the default Catmull-Rom; the render's choice) */
    /* Sky ordinates' spacing in smallest voxel lengths (across and along their columns);
     * 0: by their share of the light (the rule above); negative: the suns' (the oversample's,
     * which suns and point lights always keep). */
    double sky_spacing;
} vdbs_light_grid_desc;

/* What building a set cost and holds. */
typedef struct vdbs_light_grid_stats {
    int64_t cells;         /* samples of all grids, n0 n1 n2 summed */
    int64_t columns;       /* n0 n1 summed */
    int64_t columns_empty; /* columns that met no density: swept, nothing stored */
    int64_t stored;        /* depth samples stored */
    double seconds_sweep;  /* wall time of the sweeps (packing included) */
    /* The directional grids' spacings (world; 0 without one), smallest and largest. */
    double spacing_min, spacing_max;
} vdbs_light_grid_stats;

typedef struct vdbs_light_grids {
    uint32_t *words; /* the set (shaders/vs_lightgrid.h) */
    size_t word_count;
    int count;
    float medium[4 * VDBS_MEDIUM_TABLE_ENTRIES]; /* the table the grids were swept with */
    vdbs_light_grid_stats stats;
} vdbs_light_grids;

/* One grid per light of the table's lights [first, first + count), lights numbered as the
 * kernels do: the direct lights, then the sky ordinates. A sun or ordinate gets a
 * directional grid (sky light travels away from its sky), a point light a radial one. The
 * medium (density scale) is the scene's. Errors: a grid too large (VDBS_ERR_INPUT), out of
 * memory, GPU errors. */
vdbs_status vdbs_light_grids_build(vdbs_runner *runner, const vdbs_volume *volume,
                                   const vdbs_scene *scene, const vdbs_light_table *lights,
                                   int first, int count, const vdbs_light_grid_desc *desc,
                                   vdbs_light_grids *grids, vdbs_error *err);
void vdbs_light_grids_free(vdbs_light_grids *grids);

/* The optical depth towards the light of grid `grid` at an index-space point (the shared
 * lookup, C path). */
float vdbs_light_grids_depth(const vdbs_light_grids *grids, int grid, const double index[3]);

/* The same lookup at every output voxel of the volume (depth holds volume->coord_count
 * floats), on the runner's backend. */
vdbs_status vdbs_light_grids_lookup_voxels(vdbs_runner *runner, const vdbs_volume *volume,
                                           const vdbs_light_grids *grids, int grid, float *depth,
                                           vdbs_error *err);

/* What vdbs_light_grids_build would allocate for the same arguments (bake and render check
 * it against --max-memory before they build): planned as the build plans, stored samples
 * estimated (a live column's whole length at most, the occupied bricks' cells at most). */
typedef struct vdbs_light_grids_memory {
    int64_t peak;     /* bytes while building the set (words, sweep tile, sample store) */
    int64_t peak_one; /* the same for the largest grid built on its own (count 1) */
    int64_t held;     /* bytes of the built set */
    int64_t samples;  /* depth samples stored (vdbs_light_grids_samples keeps about as many) */
    int64_t columns, cells;
} vdbs_light_grids_memory;

vdbs_status vdbs_light_grids_estimate(const vdbs_volume *volume, const vdbs_light_table *lights,
                                      int first, int count, const vdbs_light_grid_desc *desc,
                                      vdbs_light_grids_memory *memory, vdbs_error *err);

/* On the GPU, whether the set fits one storage buffer (VDBS_ERR_GPU naming --s1-oversample,
 * --quality and --backend cpu if not); always VDBS_OK on the C path. */
vdbs_status vdbs_light_grids_fit(vdbs_runner *runner, const vdbs_light_grids *grids,
                                 vdbs_error *err);

/* Columns n0 x n1 and samples per column n2 of grid `grid`. */
void vdbs_light_grids_shape(const vdbs_light_grids *grids, int grid, int n[3]);

/* A light grid's samples as a sparse grid of their own (a lit VDB's stored depths,
 * docs/lit-vdb.md): sample k of column (i, j) at (i, j, k), so that trilinear interpolation in
 * (i, j, k) is the lookup's rule (bilinear across columns, linear along them). A directional
 * grid comes with the affine map from (i, j, k) to the volume's index space; a radial grid's
 * (i, j, k) are (octahedral texel, texel, shell), with its texels across and shell radii.
 * Kept: every sample whose value is not 0 and that an interpolation can reach, i.e. each
 * column from its first stored sample to one past the last that any column around it stores
 * (its constant tail as far as theirs reaches). */
typedef struct vdbs_light_grid_samples {
    int32_t *coords; /* (i, j, k) per sample */
    float *values;
    size_t count;
    double to_index[3][4]; /* directional: (i, j, k, 1) -> the volume's index space */
    int radial;            /* 1: a point light's radial grid */
    int texels;            /* radial: texels across the octahedral map */
    float *radii;          /* radial: the shells' radii (world), `shells` of them */
    int shells;
} vdbs_light_grid_samples;

/* Errors: out of memory. */
vdbs_status vdbs_light_grids_samples(const vdbs_light_grids *grids, int grid,
                                     vdbs_light_grid_samples *out, vdbs_error *err);
void vdbs_light_grid_samples_free(vdbs_light_grid_samples *samples);

/* Sample k of column (i, j) of grid `grid`: the swept optical depth as stored. */
float vdbs_light_grids_sample(const vdbs_light_grids *grids, int grid, int i, int j, int k);

#ifdef __cplusplus
}
#endif

#endif
