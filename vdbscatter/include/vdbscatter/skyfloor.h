/* The uniform part of a sky, which FLD and SVD carry through their grids' boundaries rather
 * than as first collisions (docs/design.md "The sky's uniform part"). A radiance arriving
 * alike from every direction is what both solvers' boundary conditions hold exactly: under it
 * and albedo 1 every cell's fluence is 4 pi times it (the white furnace), while first
 * collisions from a light grid and a coarse solve agree only to the grid's truncation. The
 * floor is per channel the least radiance of the sky ordinates, so that every ordinate keeps
 * a non-negative remainder for the first collisions. The solve then carries the floor's
 * unscattered light with its scattered light, and each voxel's own unscattered share (exact,
 * from the light grids) is taken off `ms` again. */
#ifndef VDBSCATTER_SKYFLOOR_H
#define VDBSCATTER_SKYFLOOR_H

#include <stddef.h>

#include "vdbscatter/coarse.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The solvers' choice of how the sky enters (--fld-sky, --svd-sky): "collisions" (index 0,
 * the default: the whole sky as first collisions) or "boundary" (its uniform part through the
 * grid's boundary). */
extern const char *const vdbs_sky_floor_ways[];
#define VDBS_SKY_BOUNDARY 1

typedef struct vdbs_sky_floor {
    double radiance[3]; /* per channel; all 0: no floor (no sky, or a black direction) */
    float *s1;          /* 3 per output voxel: the floor's unscattered fluence over 4 pi */
    double *flux;       /* 9 per output voxel: its unscattered net flux (x, y, z of R, G, B) */
} vdbs_sky_floor;

/* The scene's floor; its voxel arrays only where it is not 0. */
vdbs_status vdbs_sky_floor_init(vdbs_sky_floor *floor, const vdbs_volume *volume,
                                const vdbs_light_table *lights, vdbs_error *err);
/* 1 when the floor carries light. */
int vdbs_sky_floor_active(const vdbs_sky_floor *floor);
/* Sky ordinate `light` (>= lights->direct_count) from its optical depth at every output voxel:
 * adds the floor's part of its unscattered light (radiance floor over the ordinate's solid
 * angle) and gives in rest[ch] the share of its irradiance left to the first collisions,
 * 1 - floor / its radiance. */
void vdbs_sky_floor_light(vdbs_sky_floor *floor, const vdbs_volume *volume,
                          const vdbs_light_table *lights, int light, const float *depth,
                          double rest[3]);
/* Before the upsampling: the floor's unscattered flux off a solve's cell flux (9 per cell of
 * f), each voxel's splatted into the cells around it, so that ms_l1 is the scattered light's
 * alone, at the scale it was solved on. Measured on the cloud sample (image relative RMSE at
 * low, FLD / SVD): off the cells 0.088 / 0.055, off the voxels 0.127 (blotches: the cells'
 * smooth flux less the voxels' sharp one) / 0.045, left in 0.072 / 0.080; none wins
 * everywhere (SVD at high: 0.050, 0.055, 0.047). */
void vdbs_sky_floor_take_flux(const vdbs_sky_floor *floor, const vdbs_volume *volume,
                              const vdbs_coarse_frame *f, double *flux);
/* After the upsampling: the floor's unscattered light off each voxel's ms (never below 0;
 * radiance follows). */
void vdbs_sky_floor_remove(const vdbs_sky_floor *floor, size_t count, float *ms, float *radiance);
void vdbs_sky_floor_free(vdbs_sky_floor *floor);

#ifdef __cplusplus
}
#endif

#endif
