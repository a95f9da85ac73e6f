#include "vdbscatter/single.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/medium.h"

#include "vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_march.h"
#include "vs_single.h"

typedef struct single_job {
    const vdbs_volume *volume;
    const vs_vec4 *medium_data;
    const vs_vec4 *light_data;
    float *radiance;
} single_job;

static void single_items(void *user, uint64_t begin, uint64_t end)
{
    const single_job *job = user;
    pnanovdb_buf_t buf = pnanovdb_make_buf(job->volume->nano, job->volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    for (uint64_t n = begin; n < end; ++n) {
        const int32_t *c = job->volume->coords + 3 * n;
        pnanovdb_vec3_t s = vs_single_average(job->medium_data, job->light_data, buf, &acc,
                                              vs_coord(c[0], c[1], c[2]));
        job->radiance[3 * n] = s.x;
        job->radiance[3 * n + 1] = s.y;
        job->radiance[3 * n + 2] = s.z;
    }
}

vdbs_status vdbs_single_scatter(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, const vdbs_light_table *lights,
                                float *radiance, vdbs_progress *progress, vdbs_error *err)
{
    vdbs_medium medium_params;
    vdbs_medium_init(&medium_params, volume, scene);
    float medium[4 * VDBS_MEDIUM_TABLE_ENTRIES];
    vdbs_medium_pack(&medium_params, medium);
    single_job job = {volume, (const vs_vec4 *)medium, (const vs_vec4 *)lights->packed, radiance};

    vdbs_kernel_desc desc = {0};
    desc.items = volume->coord_count;
    desc.user = &job;
    desc.cpu_items = single_items;
    desc.shader = "single_scatter.comp";
    desc.inputs[0] = (vdbs_kernel_input){volume->nano, volume->nano_size};
    desc.inputs[1] = (vdbs_kernel_input){medium, sizeof medium};
    desc.inputs[2] =
        (vdbs_kernel_input){lights->packed, lights->packed_entries * 4 * sizeof(float)};
    desc.inputs[3] = (vdbs_kernel_input){volume->coords, 3 * sizeof(int32_t) * volume->coord_count};
    desc.state_words = 3;
    desc.output_words = 3;
    desc.output = radiance;
    desc.units_per_dispatch = vdbs_volume_gpu_marches_per_pass(volume);
    desc.total_units = lights->direct_count + lights->ordinate_count;
    /* Short dispatches keep a display driver's watchdog quiet on real GPUs. */
    desc.gpu_chunk = 1u << 16;
    desc.progress = progress;
    return vdbs_kernel_run(runner, &desc, NULL, err);
}

/* Adds colour * exp(-depth) (over r^2 for a point light at `point`, else NULL) to every
 * output voxel's fluence. */
static void add_light(const vdbs_volume *volume, const float *depth, const double color[3],
                      const double *point, double min_distance, double *fluence)
{
    const int64_t count = (int64_t)volume->coord_count;
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        double weight = exp(-(double)depth[n]);
        if (point) {
            const int32_t *c = volume->coords + 3 * n;
            double index[3] = {c[0], c[1], c[2]}, world[3];
            vdbs_volume_world_point(volume, index, world);
            double d[3] = {world[0] - point[0], world[1] - point[1], world[2] - point[2]};
            double rc = fmax(sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), min_distance);
            weight /= rc * rc;
        }
        for (int ch = 0; ch < 3; ++ch)
            fluence[3 * n + ch] += color[ch] * weight;
    }
}

vdbs_status vdbs_single_scatter_grids(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_scene *scene, const vdbs_light_table *lights,
                                      const vdbs_light_grid_desc *grids, float *radiance,
                                      vdbs_s1_stats *stats, vdbs_progress *progress,
                                      vdbs_error *err)
{
    vdbs_s1_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    const size_t n = volume->coord_count;
    if (n == 0)
        return VDBS_OK; /* an empty grid: nothing to light, no grid to build */
    double *fluence = calloc(3 * n, sizeof *fluence);
    float *depth = malloc(n * sizeof *depth);
    if (!fluence || !depth) {
        free(fluence);
        free(depth);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu voxels", n);
    }
    vdbs_status st = VDBS_OK;
    const int total = lights->direct_count + lights->ordinate_count;
    for (int d = 0; d < total && st == VDBS_OK; ++d) {
        vdbs_light_grids set;
        st = vdbs_light_grids_build(runner, volume, scene, lights, d, 1, grids, &set, err);
        if (st != VDBS_OK)
            break;
        double t0 = omp_get_wtime();
        st = vdbs_light_grids_lookup_voxels(runner, volume, &set, 0, depth, err);
        if (st == VDBS_OK) {
            double color[3];
            const double *point = NULL;
            if (d < lights->direct_count) {
                memcpy(color, lights->direct[d].color, sizeof color);
                if (lights->direct[d].type == VDBS_LIGHT_POINT)
                    point = lights->direct[d].world;
            } else {
                const vdbs_sky_ordinate *o = &lights->ordinates[d - lights->direct_count];
                for (int a = 0; a < 3; ++a)
                    color[a] = o->radiance[a] * o->weight;
            }
            add_light(volume, depth, color, point, lights->min_distance, fluence);
        }
        stats->seconds_lookup += omp_get_wtime() - t0;
        stats->grids.cells += set.stats.cells;
        stats->grids.columns += set.stats.columns;
        stats->grids.columns_empty += set.stats.columns_empty;
        stats->grids.stored += set.stats.stored;
        stats->grids.seconds_sweep += set.stats.seconds_sweep;
        vdbs_light_grids_free(&set);
        if (progress)
            vdbs_progress_update(progress, (uint64_t)n * (uint64_t)(d + 1) / (uint64_t)total);
    }
    if (st == VDBS_OK)
        for (size_t v = 0; v < 3 * n; ++v)
            radiance[v] = (float)(fluence[v] * VDBS_INV_4PI);
    free(fluence);
    free(depth);
    return st;
}
