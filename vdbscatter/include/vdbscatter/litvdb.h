/* Reading the grids of a lit VDB written by `vdbscatter bake` (docs/lit-vdb.md),
 * beside the VDB I/O: the multiple-scattering grids as NanoVDB buffers that the render
 * kernel samples. */
#ifndef VDBSCATTER_LITVDB_H
#define VDBSCATTER_LITVDB_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The lit VDB's format version (metadata `vdbscatter_format`; files without it are 1):
 * 2 adds the optical depth toward every light (docs/lit-vdb.md). */
#define VDBS_LIT_FORMAT 2

/* Grid names of the stored optical depths, light `light` of a light table (lights.h: the
 * direct lights, then the sky ordinates; `direct` of them direct): "light_depth_000", ...,
 * then "sky_depth_0000", .... */
void vdbs_lit_depth_name(int light, int direct, char *name, size_t size);

/* The grids of a lit VDB that the render samples, as NanoVDB buffers (32-byte aligned,
 * sizes multiples of 32) on the density's index space:
 * - ms, l1x, l1y, l1z: Vec3f; all four are set or all are NULL (Sms is then 0: single mode);
 * - depth: per light of the table, the optical depth toward it at the voxel centres (float
 *   grids): single scattering from these instead of light grids swept at render time.
 *   depth_count 0: none (format 1, `bake --store none`, or not asked for). */
/* One stored depth grid: where its own index space lies. */
typedef struct vdbs_lit_depth {
    uint32_t *grid; /* NanoVDB float grid */
    size_t size;
    /* affine: density index -> the grid's (a sun's or sky ordinate's grid lies in the
     * light's frame) */
    double to_grid[3][4];
    /* a point light's grid: (octahedral texel, texel, shell) of `texels` across and `shells`
     * radii (world), from the file's vdbscatter_lights */
    int radial, texels, shells;
    float *radii;
} vdbs_lit_depth;

typedef struct vdbs_lit_grids {
    uint32_t *ms, *l1x, *l1y, *l1z;
    size_t ms_size, l1x_size, l1y_size, l1z_size;
    vdbs_lit_depth *depth;
    int depth_count;
    int depth_direct; /* how many of depth[] are direct lights (the rest sky ordinates) */
} vdbs_lit_grids;

/* Converts the lit VDB's `ms`, `ms_l1x`, `ms_l1y`, `ms_l1z` grids and, with `depths`, every
 * stored optical depth (light_depth_*, then sky_depth_*, numbered from 0 without gaps).
 * `index_to_world` is the density grid's transform (vdbs_volume.index_to_world), which the
 * ms grids must share (the kernel samples them in the density's index space); a depth grid
 * has its own index space (vdbs_lit_depth). Errors
 * (VDBS_ERR_INPUT): a grid missing or of another type, or on another transform. */
vdbs_status vdbs_lit_grids_load(const vdbio_lit *lit, const double index_to_world[3][4], int depths,
                                vdbs_lit_grids *out, vdbs_error *err);
void vdbs_lit_grids_free(vdbs_lit_grids *grids);
/* Whether all four ms grids are there. */
int vdbs_lit_grids_have_ms(const vdbs_lit_grids *grids);

#ifdef __cplusplus
}
#endif

#endif
