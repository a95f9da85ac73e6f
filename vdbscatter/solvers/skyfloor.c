#include "vdbscatter/skyfloor.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"
#include "vdbscatter/collision.h"

const char *const vdbs_sky_floor_ways[] = {"collisions", "boundary", NULL};

vdbs_status vdbs_sky_floor_init(vdbs_sky_floor *floor, const vdbs_volume *volume,
                                const vdbs_light_table *lights, vdbs_error *err)
{
    memset(floor, 0, sizeof *floor);
    for (int ch = 0; ch < 3 && lights->ordinate_count > 0; ++ch) {
        double least = HUGE_VAL;
        for (int k = 0; k < lights->ordinate_count; ++k)
            least = fmin(least, lights->ordinates[k].radiance[ch]);
        floor->radiance[ch] = least > 0.0 ? least : 0.0;
    }
    if (!vdbs_sky_floor_active(floor))
        return VDBS_OK;
    const size_t count = volume->coord_count ? volume->coord_count : 1;
    floor->s1 = calloc(3 * count, sizeof *floor->s1);
    floor->flux = calloc(9 * count, sizeof *floor->flux);
    if (!floor->s1 || !floor->flux) {
        vdbs_sky_floor_free(floor);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the sky of %zu voxels",
                              count);
    }
    return VDBS_OK;
}

int vdbs_sky_floor_active(const vdbs_sky_floor *floor)
{
    return floor->radiance[0] > 0.0 || floor->radiance[1] > 0.0 || floor->radiance[2] > 0.0;
}

void vdbs_sky_floor_light(vdbs_sky_floor *floor, const vdbs_volume *volume,
                          const vdbs_light_table *lights, int light, const float *depth,
                          double rest[3])
{
    const vdbs_sky_ordinate *o = &lights->ordinates[light - lights->direct_count];
    double part[3], travel[3];
    for (int ch = 0; ch < 3; ++ch) {
        const double r = o->radiance[ch];
        rest[ch] = r > 0.0 ? 1.0 - floor->radiance[ch] / r : 0.0;
        part[ch] = r > 0.0 ? floor->radiance[ch] * o->weight : 0.0;
        travel[ch] = -o->world[ch];
    }
    if (!floor->s1)
        return;
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < (int64_t)volume->coord_count; ++n) {
        const double t = vdbs_beam_transmittance(1.0, depth[n]);
        for (int ch = 0; ch < 3; ++ch) {
            floor->s1[3 * n + ch] += (float)(part[ch] * t * VDBS_INV_4PI);
            for (int a = 0; a < 3; ++a)
                floor->flux[9 * n + 3 * a + ch] += part[ch] * t * travel[a];
        }
    }
}

void vdbs_sky_floor_take_flux(const vdbs_sky_floor *floor, const vdbs_volume *volume,
                              const vdbs_coarse_frame *f, double *flux)
{
    if (!floor->flux)
        return;
    const double scale = -vdbs_volume_voxel_volume(volume) / vdbs_coarse_cell_volume(f);
    for (size_t n = 0; n < volume->coord_count; ++n) {
        double w[3];
        vdbs_volume_voxel_point(volume, n, w);
        vdbs_coarse_splat(f, flux, 9, w, floor->flux + 9 * n, scale);
    }
}

void vdbs_sky_floor_remove(const vdbs_sky_floor *floor, size_t count, float *ms, float *radiance)
{
    if (!floor->s1)
        return;
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < 3 * (int64_t)count; ++i) {
        const float m = fmaxf(ms[i] - floor->s1[i], 0.0f);
        radiance[i] += m - ms[i];
        ms[i] = m;
    }
}

void vdbs_sky_floor_free(vdbs_sky_floor *floor)
{
    free(floor->s1);
    free(floor->flux);
    memset(floor, 0, sizeof *floor);
}
