/* The medium: sigma_t = density * density_scale, sigma_s = albedo sigma_t and the HG g of a
 * volume, as the kernels read them (shaders/vs_medium.h). */
#ifndef VDBSCATTER_MEDIUM_H
#define VDBSCATTER_MEDIUM_H

#include "vdbscatter/scene.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Entries (4 floats each) of the kernels' medium table. */
#define VDBS_MEDIUM_TABLE_ENTRIES 10

/* The kernels' medium table for a volume and the scene's medium parameters. */
void vdbs_medium_pack(const vdbs_volume *volume, const vdbs_scene *scene,
                      float table[4 * VDBS_MEDIUM_TABLE_ENTRIES]);

#ifdef __cplusplus
}
#endif

#endif
