/* Radial frames: the coarse grids that POP propagates point lights and the camera's importance
 * on (Elek et al. 2014, Secs. 6 and 5.2): texels of an angular map around a
 * centre times shells outwards. Cell (i, j, k) is texel (i, j) between the shell radii
 * radius[k] and radius[k + 1]; item (k n1 + j) n0 + i, as in the kernels (shaders/vs_pop.h).
 *
 * - octahedral (a point light): n x n texels of the octahedral map over the whole sphere
 *   (n even), shells from the centre: radius[0] = 0 and radius[1 ..] growing geometrically to
 *   the outer radius, in proportion to a texel's width where the shell count allows (cells
 *   about as long as wide), otherwise from the inner radius (where the medium starts);
 * - perspective (the camera): n x n texels of the image plane of a pinhole camera, shells
 *   growing geometrically from the near to the far radius.
 *
 * Both maps have the solid angle dOmega = dA / |p|^3 per area of the plane (p the unnormalised
 * direction, on the octahedron |x| + |y| + |z| = 1 or the image plane at distance 1); texel
 * solid angles are integrated from it (the octahedral ones scaled to sum to 4 pi exactly). */
#ifndef VDBSCATTER_RADIAL_H
#define VDBSCATTER_RADIAL_H

#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbs_radial_map {
    VDBS_RADIAL_OCTAHEDRAL = 0,
    VDBS_RADIAL_PERSPECTIVE
} vdbs_radial_map;

/* Most parts per axis a cell is split into (vdbs_radial_cell_parts). */
#define VDBS_RADIAL_MAX_SPLIT 4
#define VDBS_RADIAL_MAX_PARTS                                                                      \
    (VDBS_RADIAL_MAX_SPLIT * VDBS_RADIAL_MAX_SPLIT * VDBS_RADIAL_MAX_SPLIT)

typedef struct vdbs_radial_frame {
    vdbs_radial_map map;
    double centre[3];                   /* world */
    double forward[3], right[3], up[3]; /* perspective: the camera's frame */
    double tan_half[2];                 /* perspective: half the image plane's width, height */
    int n[3];                           /* texels n0 x n1, shells n2 */
    double *radius;                     /* n2 + 1 shell radii (world) */
    double *omega;                      /* n0 n1 texel solid angles */
    double *dir;                        /* 3 n0 n1: unit direction of each texel's centre */
} vdbs_radial_frame;

/* Octahedral frame of `texels` x `texels` (even, >= 2) and `shells` (>= 1) around centre;
 * r_inner (>= 0): where the medium starts, r_outer (> r_inner): where it ends. Errors:
 * those shapes (VDBS_ERR_INPUT), out of memory. */
vdbs_status vdbs_radial_octahedral(const double centre[3], int texels, int shells, double r_inner,
                                   double r_outer, vdbs_radial_frame *f, vdbs_error *err);
/* Perspective frame over a camera's field of view, shells from r_near (> 0) to r_far. */
vdbs_status vdbs_radial_perspective(const vdbs_camera_frame *camera, int texels, int shells,
                                    double r_near, double r_far, vdbs_radial_frame *f,
                                    vdbs_error *err);
void vdbs_radial_free(vdbs_radial_frame *f);

int64_t vdbs_radial_cells(const vdbs_radial_frame *f);
/* The unit direction at texel coordinates (x, y) (texel (i, j) spans [i, i + 1] x [j, j + 1])
 * and the solid angle per unit texel area there (returned). */
double vdbs_radial_direction(const vdbs_radial_frame *f, double x, double y, double dir[3]);
/* Volume of a cell, and its volume per unit radial length (the kernel's vs_pop_radial_area). */
double vdbs_radial_cell_volume(const vdbs_radial_frame *f, int64_t cell);
double vdbs_radial_cell_area(const vdbs_radial_frame *f, int64_t cell);
/* World point at a cell's centroid radius along its texel's centre direction. */
void vdbs_radial_cell_centroid(const vdbs_radial_frame *f, int64_t cell, double world[3]);
/* The cell split into m^3 parts no wider than `side` (m <= VDBS_RADIAL_MAX_SPLIT): m x m in
 * texel coordinates, m equal steps in r. Writes each part's world centroid (3 doubles) and
 * volume (summing to the cell's), and returns the count m^3. */
int vdbs_radial_cell_parts(const vdbs_radial_frame *f, int64_t cell, double side, double *world,
                           double *volume);
/* sigma_t of every cell: density_scale times the box-filtered density averaged over the cell's
 * parts no wider than side; VDBS_RADIAL_OUTSIDE (the kernel's "outside", shaders/vs_pop.h)
 * for a cell with no part in the support box. */
#define VDBS_RADIAL_OUTSIDE (-1.0f)
void vdbs_radial_sigma(const vdbs_radial_frame *f, const vdbs_volume *volume,
                       const vdbs_medium_box *box, double density_scale, double side, float *sigma);

#ifdef __cplusplus
}
#endif

#endif
