#include "vdbscatter/bake.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/gpu.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/single.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifndef VDBSCATTER_VERSION
#define VDBSCATTER_VERSION "0"
#endif

vdbs_status vdbs_backend_parse(const char *text, vdbs_backend *backend, vdbs_error *err)
{
    if (strcmp(text, "auto") == 0)
        *backend = VDBS_BACKEND_AUTO;
    else if (strcmp(text, "cpu") == 0)
        *backend = VDBS_BACKEND_CPU;
    else if (strcmp(text, "gpu") == 0)
        *backend = VDBS_BACKEND_GPU;
    else
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--backend: expected auto, cpu or gpu, got '%s'",
                              text);
    return VDBS_OK;
}

static void warn(const vdbs_bake_options *o, const char *fmt, const char *arg)
{
    char line[512];
    snprintf(line, sizeof line, fmt, arg);
    if (o->warn)
        o->warn(o->warn_user, line);
}

/* Solves S1 into radiance (3 floats per output voxel) on the chosen backend. */
static vdbs_status solve_single(const vdbs_bake_options *o, const vdbs_volume *volume, int sky,
                                float *radiance, vdbs_bake_report *report, vdbs_error *err)
{
    vdbs_backend backend = o->backend;
    if (backend == VDBS_BACKEND_AUTO)
        backend = vdbs_gpu_hardware_available() ? VDBS_BACKEND_GPU : VDBS_BACKEND_CPU;
    vdbs_progress progress;
    vdbs_progress_begin(&progress, o->progress, "single scattering", volume->coord_count);
    vdbs_status st;
    if (backend == VDBS_BACKEND_GPU) {
        vdbs_gpu *gpu = NULL;
        st = vdbs_gpu_create(&gpu, err);
        if (st != VDBS_OK)
            return st;
        snprintf(report->backend, sizeof report->backend, "gpu");
        snprintf(report->renderer, sizeof report->renderer, "%s", vdbs_gpu_get_info(gpu)->renderer);
        st = vdbs_single_scatter_gpu(gpu, volume, o->scene, sky, radiance, &progress, err);
        vdbs_gpu_destroy(gpu);
    } else {
        snprintf(report->backend, sizeof report->backend, "cpu");
        snprintf(report->renderer, sizeof report->renderer, "C (OpenMP, %d threads)",
                 omp_get_max_threads());
        st = vdbs_single_scatter_cpu(volume, o->scene, sky, radiance, &progress, err);
    }
    if (st == VDBS_OK)
        vdbs_progress_end(&progress);
    return st;
}

static char *format_double(double v)
{
    char *s = malloc(32);
    if (s)
        snprintf(s, 32, "%.17g", v);
    return s;
}

vdbs_status vdbs_bake(const vdbs_bake_options *o, vdbs_bake_report *report, vdbs_error *err)
{
    const vdbs_scene *scene = o->scene;
    memset(report, 0, sizeof *report);
    double t_start = vdbs_now();
    const char *input = o->input ? o->input : scene->volume_file;
    if (!input || !input[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT, "no input volume given");
    if (strcmp(scene->method, "single") != 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--method %s is not implemented yet (available: single)",
                              scene->method);
    vdbs_status st = vdbio_check_output(o->output, input, err);
    if (st != VDBS_OK)
        return st;
    int sky = vdbs_quality_sky_directions(scene->quality);
    if (sky <= 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown quality '%s'", scene->quality);
    for (int i = 0; i < scene->light_count; ++i)
        if (scene->lights[i].type == VDBS_LIGHT_SUN && scene->lights[i].angular_diameter_deg > 0)
            warn(o, "%s",
                 "sun angular_diameter_deg is treated as 0 (a delta light) by --method "
                 "single");

    vdbio_read_options read = {0};
    read.grid_name = scene->grid[0] ? scene->grid : NULL;
    read.grid_index = scene->grid_index;
    read.from_levelset = o->from_levelset;
    read.warn = o->warn;
    read.warn_user = o->warn_user;
    vdbs_volume volume;
    st = vdbs_volume_load(input, &read, &volume, err);
    if (st != VDBS_OK)
        return st;
    report->seconds_load = vdbs_now() - t_start;
    snprintf(report->grid, sizeof report->grid, "%s", volume.info.name);
    report->active_voxels = volume.info.active_voxels;
    report->output_voxels = volume.coord_count;
    report->sky_directions = sky;

    size_t n = volume.coord_count ? volume.coord_count : 1;
    float *radiance = calloc(3 * n, sizeof(float));
    float *zero = calloc(3 * n, sizeof(float));
    char *scene_json = vdbs_scene_to_json(scene);
    if (!radiance || !zero || !scene_json) {
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu output voxels", n);
        goto done;
    }
    double t_solve = vdbs_now();
    st = solve_single(o, &volume, sky, radiance, report, err);
    report->seconds_solve = vdbs_now() - t_solve;
    if (st != VDBS_OK)
        goto done;
    for (size_t v = 0; v < volume.coord_count; ++v)
        for (int c = 0; c < 3; ++c)
            report->radiance_max[c] = fmaxf(report->radiance_max[c], radiance[3 * v + c]);

    char sky_text[16], solve_text[32];
    snprintf(sky_text, sizeof sky_text, "%d", sky);
    snprintf(solve_text, sizeof solve_text, "%.6f", report->seconds_solve);
    char *scale = format_double(scene->density_scale);
    char *g = format_double(scene->g);
    char albedo[96];
    snprintf(albedo, sizeof albedo, "%.9g,%.9g,%.9g", scene->albedo[0], scene->albedo[1],
             scene->albedo[2]);
    vdbio_meta meta[] = {
        {"vdbscatter_version", VDBSCATTER_VERSION},
        {"vdbscatter_method", scene->method},
        {"vdbscatter_quality", scene->quality},
        {"vdbscatter_sky_directions", sky_text},
        {"vdbscatter_density_scale", scale ? scale : ""},
        {"vdbscatter_albedo", albedo},
        {"vdbscatter_g", g ? g : ""},
        {"vdbscatter_backend", report->backend},
        {"vdbscatter_solve_seconds", solve_text},
        {"vdbscatter_scene", scene_json},
    };
    vdbio_vec3_grid grids[] = {
        {"radiance", radiance}, {"ms", zero}, {"ms_l1x", zero}, {"ms_l1y", zero}, {"ms_l1z", zero},
    };
    vdbio_write_request request = {0};
    request.density = volume.density;
    request.coords = volume.coords;
    request.coord_count = volume.coord_count;
    request.vec3_grids = grids;
    request.vec3_grid_count = (int)(sizeof grids / sizeof grids[0]);
    request.file_meta = meta;
    request.file_meta_count = (int)(sizeof meta / sizeof meta[0]);
    request.half = o->half;
    request.warn = o->warn;
    request.warn_user = o->warn_user;
    double t_write = vdbs_now();
    st = vdbio_write(o->output, input, &request, err);
    report->seconds_write = vdbs_now() - t_write;
    free(scale);
    free(g);
done:
    report->seconds_total = vdbs_now() - t_start;
    free(scene_json);
    free(zero);
    free(radiance);
    vdbs_volume_free(&volume);
    return st;
}
