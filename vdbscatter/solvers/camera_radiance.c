#include "vdbscatter/camera_radiance.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_phase.h"

float *vdbs_view_directions(const vdbs_volume *volume, const double eye[3])
{
    const int64_t count = (int64_t)volume->coord_count;
    float *wo = malloc(sizeof *wo * 3 * (size_t)(count > 0 ? count : 1));
    if (!wo)
        return NULL;
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        double x[3];
        vdbs_volume_voxel_point(volume, (size_t)n, x);
        double d[3] = {eye[0] - x[0], eye[1] - x[1], eye[2] - x[2]};
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; ++a)
            wo[3 * n + a] = len > 0.0 ? (float)(d[a] / len) : (a == 2 ? 1.0f : 0.0f);
    }
    return wo;
}

void vdbs_view_add_ms(const vdbs_volume *volume, const float *wo, const float *ms,
                      float *const ms_l1[3], float *view)
{
    const int64_t count = (int64_t)volume->coord_count;
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        pnanovdb_vec3_t w = vs_vec3(wo[3 * n], wo[3 * n + 1], wo[3 * n + 2]);
        for (int ch = 0; ch < 3; ++ch) {
            size_t at = 3 * (size_t)n + (size_t)ch;
            view[at] += vs_ms_channel(ms[at], ms_l1[0][at], ms_l1[1][at], ms_l1[2][at], w);
        }
    }
}
