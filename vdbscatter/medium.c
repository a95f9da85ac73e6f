#include "vdbscatter/medium.h"

#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_medium.h"

_Static_assert(VDBS_MEDIUM_TABLE_ENTRIES == VS_MEDIUM_SIZE, "medium table size");

static void put(float *entry, double x, double y, double z, double w)
{
    entry[0] = (float)x;
    entry[1] = (float)y;
    entry[2] = (float)z;
    entry[3] = (float)w;
}

void vdbs_medium_pack(const vdbs_volume *volume, const vdbs_scene *scene,
                      float table[4 * VDBS_MEDIUM_TABLE_ENTRIES])
{
    memset(table, 0, sizeof(float) * 4 * VDBS_MEDIUM_TABLE_ENTRIES);
    put(table + 4 * VS_MEDIUM_OFF_PARAMS, scene->density_scale, scene->g, 0.0, 0.0);
    put(table + 4 * VS_MEDIUM_OFF_ALBEDO, scene->albedo[0], scene->albedo[1], scene->albedo[2],
        0.0);
    for (int r = 0; r < 3; ++r) {
        const double *m = volume->index_to_world[r];
        const double *inv = volume->world_to_index[r];
        put(table + 4 * (VS_MEDIUM_OFF_TO_WORLD + r), m[0], m[1], m[2], 0.0);
        put(table + 4 * (VS_MEDIUM_OFF_TO_INDEX + r), inv[0], inv[1], inv[2], 0.0);
    }
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    put(table + 4 * VS_MEDIUM_OFF_BOX_LO, lo[0], lo[1], lo[2], 0.0);
    put(table + 4 * VS_MEDIUM_OFF_BOX_HI, hi[0], hi[1], hi[2], 0.0);
}
