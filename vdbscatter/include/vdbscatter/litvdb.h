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

/* Multiple-scattering grids of a lit VDB as NanoVDB Vec3f buffers (32-byte aligned, sizes
 * multiples of 32), on the density's index space. All four are set or all are NULL
 * (Sms is then 0: single mode). */
typedef struct vdbs_ms_grids {
    uint32_t *ms, *l1x, *l1y, *l1z;
    size_t ms_size, l1x_size, l1y_size, l1z_size;
} vdbs_ms_grids;

/* Converts the lit VDB's `ms`, `ms_l1x`, `ms_l1y`, `ms_l1z` grids. `index_to_world` is the
 * density grid's transform (vdbs_volume.index_to_world), which every grid must share: the
 * kernel samples them in the density's index space. Errors (VDBS_ERR_INPUT): a grid
 * missing or not vec3s, or on another transform. */
vdbs_status vdbs_ms_grids_load(const vdbio_lit *lit, const double index_to_world[3][4],
                               vdbs_ms_grids *out, vdbs_error *err);
void vdbs_ms_grids_free(vdbs_ms_grids *grids);
/* Whether all four grids are there. */
int vdbs_ms_grids_present(const vdbs_ms_grids *grids);

#ifdef __cplusplus
}
#endif

#endif
