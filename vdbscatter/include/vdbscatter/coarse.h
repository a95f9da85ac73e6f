/* Coarse world-space grids that the multiple-scattering solvers work on (POP's directional
 * and merged grids, FLD's and the discrete ordinates'), and the way back to the output voxels:
 * frames of box cells (cubic for POP) at any orientation over the support box, the medium sampled
 * per cell, energy-keeping splats between frames and joint bilateral upsampling (Elek et al.
 * Sec. 4.4). */
#ifndef VDBSCATTER_COARSE_H
#define VDBSCATTER_COARSE_H

#include <stdint.h>

#include "vdbscatter/medium.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Cell (i, j, k) is the box whose first corner is origin + i side[0] axis[0] +
 * j side[1] axis[1] + k side[2] axis[2]; item (k n1 + j) n0 + i. */
typedef struct vdbs_coarse_frame {
    double origin[3];
    double axis[3][3]; /* orthonormal */
    double side[3];    /* the cells' side along each axis: all h in a cubic frame */
    double h;          /* the largest side (a cubic frame's side: POP's frames are cubic) */
    int n[3];
} vdbs_coarse_frame;

/* The frame with the given axes spanning the box with these corners in cells of side h. */
void vdbs_coarse_fit(const double corners[8][3], const double axis[3][3], double h,
                     vdbs_coarse_frame *f);
/* Cells across each axis that vdbs_coarse_world_frame gives an axis at least (when the
 * voxels allow and the cap leaves room): measured on a thin slab (docs/design.md "Solver
 * grids"). */
#define VDBS_COARSE_MIN_ACROSS 8
/* The world-aligned frame over the volume's support box with `resolution` cells of side
 * h = extent / resolution across its extent (vdbs_volume_support_extent), never finer than one
 * mean voxel length; returns the resolution used (FLD's and the discrete ordinates' grids).
 * An axis whose extent is under min_across cells of h gets min_across cells of its own,
 * shorter side (never shorter than a mean voxel), so that a thin layer is resolved through
 * its thickness; the frame never has more than resolution^3 cells for it (the cube's count):
 * at that cap the short axes get the most cells that fit. min_across <= 1: cubic cells. */
int vdbs_coarse_world_frame(const vdbs_volume *volume, int resolution, int min_across,
                            vdbs_coarse_frame *f);
int64_t vdbs_coarse_cells(const vdbs_coarse_frame *f);
/* The world volume of one cell. */
double vdbs_coarse_cell_volume(const vdbs_coarse_frame *f);
/* World point at grid coordinates x (in cells from the origin); a cell's centre. */
void vdbs_coarse_point(const vdbs_coarse_frame *f, const double x[3], double world[3]);
void vdbs_coarse_cell_centre(const vdbs_coarse_frame *f, int64_t c, double world[3]);
/* sigma_t (density_scale times the box-filtered density) at every cell centre. */
void vdbs_coarse_sigma(const vdbs_coarse_frame *f, const vdbs_volume *volume,
                       const vdbs_medium_box *box, double density_scale, float *sigma);
/* Adds `values` (width doubles) at world point p into the cells of `dst` around it by
 * trilinear weights renormalised over the cells inside the grid, times scale: the sum over
 * the cells gains exactly scale x values. */
void vdbs_coarse_splat(const vdbs_coarse_frame *dst, double *acc, int width, const double p[3],
                       const double *values, double scale);
/* The same over the cells whose mask (one float per cell of dst) is > 0, renormalised over
 * those: returns 0, adding nothing, when none of the eight is (NULL: vdbs_coarse_splat). */
int vdbs_coarse_splat_masked(const vdbs_coarse_frame *dst, double *acc, int width,
                             const double p[3], const double *values, double scale,
                             const float *mask);

/* The transpose of the splat: values (width floats per cell) interpolated at world point p
 * with the same weights. */
void vdbs_coarse_sample(const vdbs_coarse_frame *f, const float *values, int width,
                        const double p[3], double *out);

/* Per cell of the grid that is upsampled: ms (3 channels), then ms_l1 x, y, z (3 each). */
#define VDBS_COARSE_MS 0
#define VDBS_COARSE_L1 3
#define VDBS_COARSE_WIDTH 12

/* docs/design.md's ms and ms_l1 per cell from the scattered light's fluence phi (3 per cell) and
 * net flux F (9 per cell, x, y, z of R, G, B; NULL: ms_l1 stays 0) into `values`:
 * ms = max(phi, 0) / 4 pi, ms_l1 = (3 g / 4 pi) F. */
void vdbs_coarse_ms_values(int64_t cells, const double *phi, const double *flux, double g,
                           double *values);

/* The reconstruction across the coarse cells in vdbs_coarse_upsample (docs/design.md
 * "Upsampling without seams": the kernels measured per solver). */
typedef enum vdbs_coarse_kernel {
    /* The uniform cubic B-spline over 4 x 4 x 4 cells: C2, so that the cells leave no kinks
     * in ms; it smooths the cell values ([1 4 1] / 6 per axis at a centre). POP's: its merged
     * grid is a sum of splats, and the smoothing measured closer to the reference. */
    VDBS_COARSE_BSPLINE = 0,
    /* The cubic B-spline through the cell values: its coefficients prefiltered so that the
     * spline interpolates the cells at their centres; still C2; ms clamped at 0 where it
     * overshoots. FLD's and SVD's, whose cells hold the solution itself. */
    VDBS_COARSE_BSPLINE_INTERP,
    /* Trilinear over 2 x 2 x 2 cells: C0, a kink on every plane of cell centres that close-ups
     * show as the coarse grid (the solvers' kernel before the B-splines); kept as the seam
     * measure's positive control. */
    VDBS_COARSE_TRILINEAR
} vdbs_coarse_kernel;

/* Joint bilateral upsampling of `values` (VDBS_COARSE_WIDTH per cell of f) to the output
 * voxels: the kernel's weights (cells beyond the grid clamped to its edge) times a Gaussian on
 * sigma_t, the cell's box-filtered value against the voxel's (width half the mean non-zero
 * cell value, plus 1e-3 so that no weight vanishes), renormalised. Adds ms to ms and radiance
 * (NULL: none), and the moments to ms_l1. */
vdbs_status vdbs_coarse_upsample(const vdbs_coarse_frame *f, const double *values,
                                 const vdbs_volume *volume, const vdbs_medium_box *box,
                                 double density_scale, vdbs_coarse_kernel kernel, float *ms,
                                 float *const ms_l1[3], float *radiance, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
