#include "vdbscatter/single.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_single.h"

#define VDBS_PI 3.14159265358979323846

void vdbs_sphere_directions(int count, double *dirs)
{
    const double golden_angle = VDBS_PI * (3.0 - sqrt(5.0));
    for (int k = 0; k < count; ++k) {
        double z = 1.0 - (2.0 * k + 1.0) / count;
        double r = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = golden_angle * k;
        dirs[3 * k] = r * cos(phi);
        dirs[3 * k + 1] = z;
        dirs[3 * k + 2] = r * sin(phi);
    }
}

static void set_entry(float *e, double x, double y, double z, double w)
{
    e[0] = (float)x;
    e[1] = (float)y;
    e[2] = (float)z;
    e[3] = (float)w;
}

vdbs_status vdbs_single_light_table(const vdbs_volume *volume, const vdbs_scene *scene,
                                    int sky_directions, float **data, size_t *entries,
                                    vdbs_error *err)
{
    int lights = 0, has_sky = 0;
    double sky[3];
    vdbs_status st = vdbs_scene_light_summary(scene, sky, &has_sky, &lights, err);
    if (st != VDBS_OK)
        return st;
    int k = has_sky ? sky_directions : 0;
    size_t n = VS_SINGLE_HEADER + 2 * (size_t)lights + (size_t)k;
    float *t = calloc(n, 4 * sizeof *t);
    if (!t)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the light table");

    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    set_entry(t, lights, k, scene->density_scale, 0.5 * volume->mean_voxel_size);
    for (int r = 0; r < 3; ++r)
        set_entry(t + 4 * (1 + r), volume->index_to_world[r][0], volume->index_to_world[r][1],
                  volume->index_to_world[r][2], 0.0);
    set_entry(t + 16, lo[0], lo[1], lo[2], 0.0);
    set_entry(t + 20, hi[0], hi[1], hi[2], 0.0);
    if (k > 0)
        set_entry(t + 24, sky[0] / k, sky[1] / k, sky[2] / k, 0.0);

    float *e = t + 4 * VS_SINGLE_HEADER;
    for (int i = 0; i < scene->light_count; ++i) {
        const vdbs_light *light = &scene->lights[i];
        double v[3];
        if (light->type == VDBS_LIGHT_SUN) {
            if (!vdbs_volume_sun_step(volume, light->direction, NULL, v)) {
                free(t);
                return vdbs_error_set(err, VDBS_ERR_INPUT, "sun %d has a zero direction", i);
            }
            set_entry(e, VS_LIGHT_SUN, v[0], v[1], v[2]);
        } else if (light->type == VDBS_LIGHT_POINT) {
            vdbs_volume_index_point(volume, light->position, v);
            set_entry(e, VS_LIGHT_POINT, v[0], v[1], v[2]);
        } else {
            continue;
        }
        set_entry(e + 4, light->color[0] / (4.0 * VDBS_PI), light->color[1] / (4.0 * VDBS_PI),
                  light->color[2] / (4.0 * VDBS_PI), 0.0);
        e += 8;
    }
    if (k > 0) {
        double *dirs = malloc(3 * sizeof *dirs * (size_t)k);
        if (!dirs) {
            free(t);
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for sky directions");
        }
        vdbs_sphere_directions(k, dirs);
        for (int d = 0; d < k; ++d) {
            double v[3];
            vdbs_volume_index_vector(volume, dirs + 3 * d, v);
            set_entry(e + 4 * d, v[0], v[1], v[2], 0.0);
        }
        free(dirs);
    }
    *data = t;
    *entries = n;
    return VDBS_OK;
}

vdbs_status vdbs_single_scatter_cpu(const vdbs_volume *volume, const vdbs_scene *scene,
                                    int sky_directions, float *radiance, vdbs_progress *progress,
                                    vdbs_error *err)
{
    float *table = NULL;
    size_t entries = 0;
    vdbs_status st = vdbs_single_light_table(volume, scene, sky_directions, &table, &entries, err);
    if (st != VDBS_OK)
        return st;
    const vs_vec4 *light_data = (const vs_vec4 *)table;
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    const int64_t count = (int64_t)volume->coord_count;
    int64_t done = 0;

#pragma omp parallel
    {
        pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
#pragma omp for schedule(dynamic, 256)
        for (int64_t n = 0; n < count; ++n) {
            const int32_t *c = volume->coords + 3 * n;
            pnanovdb_vec3_t s =
                vs_single_average(light_data, buf, &acc, vs_coord(c[0], c[1], c[2]));
            radiance[3 * n] = s.x;
            radiance[3 * n + 1] = s.y;
            radiance[3 * n + 2] = s.z;
            if ((n & 1023) == 1023) {
                int64_t now_done;
#pragma omp atomic capture
                now_done = done += 1024;
                if (omp_get_thread_num() == 0)
                    vdbs_progress_update(progress, (uint64_t)now_done);
            }
        }
    }
    free(table);
    return VDBS_OK;
}

vdbs_status vdbs_single_scatter_gpu(vdbs_gpu *gpu, const vdbs_volume *volume,
                                    const vdbs_scene *scene, int sky_directions, float *radiance,
                                    vdbs_progress *progress, vdbs_error *err)
{
    const vdbs_shader_source *source = vdbs_shader_find("single_scatter.comp");
    if (!source)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "shader single_scatter.comp not embedded");
    float *table = NULL;
    size_t entries = 0;
    vdbs_status st = vdbs_single_light_table(volume, scene, sky_directions, &table, &entries, err);
    if (st != VDBS_OK)
        return st;
    const uint64_t count = volume->coord_count;
    const size_t items = count ? count : 1;
    const int marches = (int)table[0] + (int)table[1];

    unsigned int program = 0, nano = 0, lights = 0, coords = 0, sums[2] = {0, 0};
    st = vdbs_gpu_program_create(gpu, source, NULL, &program, err);
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_create(gpu, volume->nano_size, volume->nano, &nano, err);
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_create(gpu, entries * 4 * sizeof(float), table, &lights, err);
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_create(gpu, 3 * sizeof(int32_t) * items, volume->coords, &coords, err);
    for (int i = 0; i < 2 && st == VDBS_OK; ++i)
        st = vdbs_gpu_buffer_create(gpu, 3 * sizeof(float) * items, NULL, &sums[i], err);
    if (st == VDBS_OK) {
        vdbs_gpu_buffer_bind(gpu, nano, 0);
        vdbs_gpu_buffer_bind(gpu, lights, 1);
        vdbs_gpu_buffer_bind(gpu, coords, 2);
    }
    int per_pass = vdbs_volume_gpu_marches_per_pass(volume);
    int first = 0, in = 0;
    while (st == VDBS_OK && first < marches && count > 0) {
        /* [0] first march, [1] march count, [2] canary trips, [3] canary step, [4] failed */
        uint32_t control[5] = {(uint32_t)first, (uint32_t)per_pass, 2u, 1u, 0u};
        unsigned int control_buffer = 0;
        st = vdbs_gpu_buffer_create(gpu, sizeof control, control, &control_buffer, err);
        if (st != VDBS_OK)
            break;
        vdbs_gpu_buffer_bind(gpu, sums[in], 3);
        vdbs_gpu_buffer_bind(gpu, sums[1 - in], 4);
        vdbs_gpu_buffer_bind(gpu, control_buffer, 5);
        st = vdbs_gpu_dispatch_items(gpu, program, count, 64, 1u << 16, NULL, NULL, err);
        if (st == VDBS_OK)
            st = vdbs_gpu_buffer_read(gpu, control_buffer, 0, sizeof control, control, err);
        vdbs_gpu_buffer_destroy(gpu, control_buffer);
        if (st != VDBS_OK)
            break;
        if (control[4]) {
            /* The input sums are untouched: repeat the pass with fewer marches. */
            if (per_pass == 1)
                st = vdbs_error_set(err, VDBS_ERR_GPU,
                                    "a single march exceeds the GPU driver's loop limit; use "
                                    "--backend cpu");
            per_pass = per_pass / 2 > 0 ? per_pass / 2 : 1;
            continue;
        }
        first += per_pass;
        in = 1 - in;
        vdbs_progress_update(progress, count * (uint64_t)(first < marches ? first : marches) /
                                           (uint64_t)marches);
    }
    if (st == VDBS_OK && count > 0)
        st = vdbs_gpu_buffer_read(gpu, sums[in], 0, 3 * sizeof(float) * count, radiance, err);
    for (int i = 0; i < 2; ++i)
        vdbs_gpu_buffer_destroy(gpu, sums[i]);
    vdbs_gpu_buffer_destroy(gpu, coords);
    vdbs_gpu_buffer_destroy(gpu, lights);
    vdbs_gpu_buffer_destroy(gpu, nano);
    if (program)
        vdbs_gpu_program_destroy(gpu, program);
    free(table);
    return st;
}
