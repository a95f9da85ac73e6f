#include "vdbscatter/single.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/medium.h"
#include "vdbscatter/camera_radiance.h"

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_march.h"
#include "vs_phase.h"
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
    desc.inputs[0] = (vdbs_kernel_input){.data = volume->nano, .size = volume->nano_size};
    desc.inputs[1] = (vdbs_kernel_input){.data = medium, .size = sizeof medium};
    desc.inputs[2] = (vdbs_kernel_input){.data = lights->packed,
                                         .size = lights->packed_entries * 4 * sizeof(float)};
    desc.inputs[3] = (vdbs_kernel_input){.data = volume->coords,
                                         .size = 3 * sizeof(int32_t) * volume->coord_count};
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

/* Adds light `light`'s colour * exp(-depth) at every output voxel (vdbs_lights_arrival) to
 * its fluence, and with view directions wo the same times the phase toward wo to view. */
static void add_light(const vdbs_volume *volume, const vdbs_light_table *lights, int light,
                      const float *depth, double g, const float *wo, double *fluence, double *view)
{
    const int64_t count = (int64_t)volume->coord_count;
    /* Only a point light's arrival depends on the point: a sun's and an ordinate's once. */
    const int varies =
        light < lights->direct_count && lights->direct[light].type == VDBS_LIGHT_POINT;
    double color0[3], travel0[3];
    const double origin[3] = {0.0, 0.0, 0.0};
    vdbs_lights_arrival(lights, light, origin, color0, travel0);
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        double world[3], color[3], travel[3];
        if (varies) {
            vdbs_volume_voxel_point(volume, (size_t)n, world);
            vdbs_lights_arrival(lights, light, world, color, travel);
        } else {
            memcpy(color, color0, sizeof color);
            memcpy(travel, travel0, sizeof travel);
        }
        const double weight = exp(-(double)depth[n]);
        double phase = 0.0;
        if (view) {
            /* 1 - mu from |travel - wo|^2 / 2 keeps the forward peak's digits. */
            double s = 0.0;
            for (int a = 0; a < 3; ++a) {
                double e = travel[a] - (double)wo[3 * n + a];
                s += e * e;
            }
            phase = vs_hg_eval_d(g, 0.5 * s);
        }
        for (int ch = 0; ch < 3; ++ch) {
            fluence[3 * n + ch] += color[ch] * weight;
            if (view)
                view[3 * n + ch] += color[ch] * weight * phase;
        }
    }
}

/* Adds one set's grid stats to a sum. */
static void grid_stats_add(vdbs_light_grid_stats *sum, const vdbs_light_grid_stats *g)
{
    sum->cells += g->cells;
    sum->columns += g->columns;
    sum->columns_empty += g->columns_empty;
    sum->stored += g->stored;
    sum->seconds_sweep += g->seconds_sweep;
    if (g->spacing_min > 0.0)
        sum->spacing_min =
            sum->spacing_min > 0.0 ? fmin(sum->spacing_min, g->spacing_min) : g->spacing_min;
    sum->spacing_max = fmax(sum->spacing_max, g->spacing_max);
}

static vdbs_s1_kind light_kind(const vdbs_light_table *lights, int light)
{
    if (light >= lights->direct_count)
        return VDBS_S1_SKY;
    return lights->direct[light].type == VDBS_LIGHT_POINT ? VDBS_S1_POINT : VDBS_S1_SUN;
}

vdbs_status vdbs_single_scatter_grids(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_scene *scene, const vdbs_light_table *lights,
                                      const vdbs_light_grid_desc *grids, float *radiance,
                                      vdbs_s1_stats *stats, vdbs_progress *progress,
                                      vdbs_error *err)
{
    vdbs_s1_outputs out = {radiance, NULL, NULL, NULL, NULL};
    return vdbs_single_scatter_grids_out(runner, volume, scene, lights, grids, &out, stats,
                                         progress, err);
}

int64_t vdbs_single_scatter_grids_bytes(const vdbs_volume *volume, int camera)
{
    /* fluence and depth below; with a camera, view and wo */
    const int64_t n = (int64_t)volume->coord_count;
    return n * (3 * (int64_t)sizeof(double) + (int64_t)sizeof(float)) +
           (camera ? n * (3 * (int64_t)sizeof(double) + 3 * (int64_t)sizeof(float)) : 0);
}

vdbs_status vdbs_single_scatter_grids_out(vdbs_runner *runner, const vdbs_volume *volume,
                                          const vdbs_scene *scene, const vdbs_light_table *lights,
                                          const vdbs_light_grid_desc *grids,
                                          const vdbs_s1_outputs *out, vdbs_s1_stats *stats,
                                          vdbs_progress *progress, vdbs_error *err)
{
    vdbs_s1_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    const size_t n = volume->coord_count;
    if (n == 0)
        return VDBS_OK; /* an empty grid: nothing to light, no grid to build */
    float *radiance = out->radiance, *radiance_view = out->radiance_view;
    double *fluence = calloc(3 * n, sizeof *fluence);
    float *depth = malloc(n * sizeof *depth);
    double *view = radiance_view ? calloc(3 * n, sizeof *view) : NULL;
    float *wo = radiance_view ? vdbs_view_directions(volume, scene->camera.position) : NULL;
    if (!fluence || !depth || (radiance_view && (!view || !wo))) {
        free(fluence);
        free(depth);
        free(view);
        free(wo);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu voxels", n);
    }
    vdbs_status st = VDBS_OK;
    const int total = lights->direct_count + lights->ordinate_count;
    for (int d = 0; d < total && st == VDBS_OK; ++d) {
        if (vdbs_progress_cancelled(progress)) {
            st = vdbs_error_cancelled(err);
            break;
        }
        vdbs_light_grids set;
        st = vdbs_light_grids_build(runner, volume, scene, lights, d, 1, grids, &set, err);
        if (st != VDBS_OK)
            break;
        double t0 = omp_get_wtime();
        if (out->light_grid)
            st = out->light_grid(out->light_user, d, &set, err);
        vdbs_s1_kind_stats *kind = &stats->kinds[light_kind(lights, d)];
        grid_stats_add(&stats->grids, &set.stats);
        kind->lights += 1;
        grid_stats_add(&kind->grids, &set.stats);
        if (st == VDBS_OK)
            st = vdbs_light_grids_lookup_voxels(runner, volume, &set, 0, depth, err);
        if (st == VDBS_OK)
            add_light(volume, lights, d, depth, scene->g, wo, fluence, view);
        if (st == VDBS_OK && out->light_depth)
            out->light_depth(out->light_user, d, depth);
        double lookup = omp_get_wtime() - t0;
        stats->seconds_lookup += lookup;
        kind->seconds_lookup += lookup;
        vdbs_light_grids_free(&set);
        if (progress)
            vdbs_progress_update(progress, (uint64_t)n * (uint64_t)(d + 1) / (uint64_t)total);
    }
    for (size_t v = 0; st == VDBS_OK && v < 3 * n; ++v) {
        if (radiance)
            radiance[v] = (float)(fluence[v] * VDBS_INV_4PI);
        if (radiance_view)
            radiance_view[v] = (float)view[v];
    }
    free(fluence);
    free(depth);
    free(view);
    free(wo);
    return st;
}
