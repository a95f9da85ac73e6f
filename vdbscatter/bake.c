#include "vdbscatter/bake.h"

#include "vdbscatter/advice.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/runner.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/camera_radiance.h"
#include "vdbscatter/volume.h"

#ifndef VDBSCATTER_VERSION
#define VDBSCATTER_VERSION "0"
#endif

static void warn(const vdbs_bake_options *o, const char *fmt, const char *arg)
{
    char line[512];
    snprintf(line, sizeof line, fmt, arg);
    if (o->warn)
        o->warn(o->warn_user, line);
}

/* Runs the scene's solver on the chosen backend; the lights are resolved here, once. */
static vdbs_status solve(const vdbs_bake_options *o, const vdbs_solver *solver,
                         const vdbs_quality *quality, const vdbs_volume *volume, vdbs_solve *s,
                         vdbs_bake_report *report, vdbs_error *err)
{
    vdbs_lights_desc lights_desc = {0};
    lights_desc.sky_ordinates =
        o->scene->sky_directions > 0 ? o->scene->sky_directions : quality->sky_directions;
    vdbs_light_table lights;
    vdbs_status st = vdbs_lights_build(volume, o->scene, &lights_desc, &lights, err);
    if (st != VDBS_OK)
        return st;
    vdbs_runner_desc runner_desc = {0};
    runner_desc.backend = o->backend;
    vdbs_runner *runner = NULL;
    st = vdbs_runner_create(&runner_desc, &runner, err);
    if (st != VDBS_OK) {
        vdbs_lights_free(&lights);
        return st;
    }
    snprintf(report->backend, sizeof report->backend, "%s", vdbs_runner_backend_name(runner));
    snprintf(report->renderer, sizeof report->renderer, "%s", vdbs_runner_device(runner));
    vdbs_progress progress = {0};
    vdbs_progress_begin(&progress, o->progress, solver->name, volume->coord_count);
    progress.cancel = o->cancel;
    s->runner = runner;
    s->volume = volume;
    s->scene = o->scene;
    s->lights = &lights;
    s->quality = quality;
    vdbs_light_grid_desc grids = {o->s1_oversample > 0 ? o->s1_oversample : quality->s1_oversample,
                                  0};
    s->s1_grids = o->s1_march ? NULL : &grids;
    s->progress = &progress;
    vdbs_s1_stats stats;
    memset(&stats, 0, sizeof stats);
    s->s1_stats = &stats;
    s->pop_stats = &report->pop;
    s->fld_stats = &report->fld;
    s->svd_stats = &report->svd;
    st = solver->run(s, err);
    vdbs_runner_transfer moved = vdbs_runner_transfers(runner);
    report->bytes_uploaded = moved.uploaded;
    report->bytes_read_back = moved.read_back;
    if (st == VDBS_OK && s->radiance_view && solver->writes_ms) {
        float *wo = vdbs_view_directions(volume, o->scene->camera.position);
        if (wo)
            vdbs_view_add_ms(volume, wo, s->ms, s->ms_l1, s->radiance_view);
        else
            st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the view directions");
        free(wo);
    }
    report->s1_grids = stats.grids;
    report->seconds_s1_lookup = stats.seconds_lookup;
    if (st == VDBS_OK)
        vdbs_progress_end(&progress);
    vdbs_runner_destroy(runner);
    vdbs_lights_free(&lights);
    return st;
}

vdbs_status vdbs_bake_volume(const vdbs_bake_options *o, const vdbs_volume *volume, float *radiance,
                             float *ms, float *const ms_l1[3], vdbs_bake_report *report,
                             vdbs_error *err)
{
    memset(report, 0, sizeof *report);
    const vdbs_solver *solver = vdbs_solver_find(o->scene->method);
    const vdbs_quality *quality = vdbs_quality_find(o->scene->quality);
    if (!solver || !quality)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown method '%s' or quality '%s'",
                              o->scene->method, o->scene->quality);
    vdbs_solve s = {0};
    s.radiance = radiance;
    s.ms = ms;
    for (int a = 0; a < 3; ++a)
        s.ms_l1[a] = ms_l1[a];
    double t0 = vdbs_now();
    vdbs_status st = solve(o, solver, quality, volume, &s, report, err);
    report->seconds_solve = report->seconds_total = vdbs_now() - t0;
    return st;
}

/* The name of moment grid k of --keep-state. */
static void svd_grid_name(int k, char *name, size_t size)
{
    snprintf(name, size, "svd_m%04d", k);
}

/* --warm-start: the moments a --keep-state bake wrote, at this volume's output voxels. */
static vdbs_status read_svd_state(const char *path, const vdbs_volume *volume, vdbs_svd_moments *m,
                                  vdbs_error *err)
{
    vdbio_lit *lit = NULL;
    vdbs_status st = vdbio_lit_open(path, &lit, err);
    if (st != VDBS_OK)
        return st;
    const char *dt = vdbio_lit_meta(lit, "vdbscatter_svd_directions");
    const char *nt = vdbio_lit_meta(lit, "vdbscatter_svd_terms");
    const char *gt = vdbio_lit_meta(lit, "vdbscatter_g");
    int directions = dt ? atoi(dt) : 0, terms = nt ? atoi(nt) : 0;
    char name[32];
    svd_grid_name(terms > 0 ? terms - 1 : 0, name, sizeof name);
    if (directions < 2 || terms < 1 || terms > directions || !gt || !vdbio_lit_has_grid(lit, name))
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "--warm-start %s: no discrete-ordinates state in it (bake it with "
                            "--method svd --keep-state)",
                            path);
    if (st == VDBS_OK)
        st = vdbs_svd_moments_alloc(m, directions, terms, strtod(gt, NULL), volume->coord_count,
                                    err);
    for (int k = 0; k < terms && st == VDBS_OK; ++k) {
        svd_grid_name(k, name, sizeof name);
        for (size_t n = 0; n < volume->coord_count && st == VDBS_OK; ++n)
            st = vdbio_lit_vec3(lit, name, volume->coords + 3 * n, m->voxels[k] + 3 * n, err);
    }
    if (st != VDBS_OK)
        vdbs_svd_moments_free(m);
    vdbio_lit_close(lit);
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
    const vdbs_solver *solver = vdbs_solver_find(scene->method);
    if (!solver) {
        char names[256];
        vdbs_solver_names(names, sizeof names);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--method %s is not implemented yet (available: %s)", scene->method,
                              names);
    }
    if ((o->keep_state || o->warm_start) && solver->method != VDBS_METHOD_SVD)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s needs --method svd",
                              o->keep_state ? "--keep-state" : "--warm-start");
    vdbs_status st = vdbio_check_output(o->output, input, err);
    if (st != VDBS_OK)
        return st;
    const vdbs_quality *quality = vdbs_quality_find(scene->quality);
    if (!quality)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown quality '%s'", scene->quality);
    const int sky = scene->sky_directions > 0 ? scene->sky_directions : quality->sky_directions;
    for (int i = 0; i < scene->light_count; ++i)
        if (scene->lights[i].type == VDBS_LIGHT_SUN && scene->lights[i].angular_diameter_deg > 0)
            warn(o, "%s",
                 "sun angular_diameter_deg is treated as 0 (a delta light) by --method "
                 "single");

    if (vdbs_cancelled(o->cancel))
        return vdbs_error_cancelled(err);
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
    /* From here on the scene as resolved against the volume (auto density scale). */
    vdbs_scene *resolved = malloc(sizeof *resolved);
    if (!resolved) {
        vdbs_volume_free(&volume);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    }
    *resolved = *o->scene;
    scene = resolved;
    if ((st = vdbs_scene_fit_density(resolved, &volume, err)) != VDBS_OK ||
        (scene->light_count == 0 &&
         (st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s", VDBS_NO_LIGHT_MESSAGE)) != VDBS_OK)) {
        free(resolved);
        vdbs_volume_free(&volume);
        return st;
    }
    report->density_scale = scene->density_scale;
    vdbs_scene_advise(scene, &volume, solver->writes_ms, o->warn, o->warn_user, &report->advice);
    vdbs_bake_options resolved_options = *o;
    resolved_options.scene = scene;
    o = &resolved_options;
    vdbs_svd_moments warm = {0}, keep = {0};
    vdbio_vec3_grid *grids = NULL;
    char(*names)[16] = NULL;
    if ((o->warm_start && ((st = read_svd_state(o->warm_start, &volume, &warm, err)) != VDBS_OK ||
                           (st = vdbs_svd_warm_check(&warm, scene->svd_directions, scene->svd_terms,
                                                     scene->g, err)) != VDBS_OK)) ||
        (vdbs_cancelled(o->cancel) && (st = vdbs_error_cancelled(err)) != VDBS_OK)) {
        vdbs_svd_moments_free(&warm);
        vdbs_volume_free(&volume);
        free(resolved);
        return st;
    }
    report->seconds_load = vdbs_now() - t_start;
    snprintf(report->grid, sizeof report->grid, "%s", volume.info.name);
    report->active_voxels = volume.info.active_voxels;
    report->output_voxels = volume.coord_count;
    report->sky_directions = sky;
    snprintf(report->s1, sizeof report->s1, "%s", o->s1_march ? "march" : "grid");
    report->s1_oversample = o->s1_march            ? 0
                            : o->s1_oversample > 0 ? o->s1_oversample
                                                   : quality->s1_oversample;

    size_t n = volume.coord_count ? volume.coord_count : 1;
    vdbs_solve outputs = {0};
    float *radiance = outputs.radiance = calloc(3 * n, sizeof(float));
    outputs.ms = calloc(3 * n, sizeof(float));
    /* Without multiple scattering the four ms grids are one array of zeros. */
    for (int a = 0; a < 3; ++a)
        outputs.ms_l1[a] = solver->writes_ms ? calloc(3 * n, sizeof(float)) : outputs.ms;
    if (scene->camera.present)
        outputs.radiance_view = calloc(3 * n, sizeof(float));
    char *scene_json = vdbs_scene_to_json(scene);
    if (!radiance || !outputs.ms || !outputs.ms_l1[0] || !outputs.ms_l1[1] || !outputs.ms_l1[2] ||
        (scene->camera.present && !outputs.radiance_view) || !scene_json) {
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu output voxels", n);
        goto done;
    }
    outputs.svd_warm = o->warm_start ? &warm : NULL;
    outputs.svd_keep = o->keep_state ? &keep : NULL;
    double t_solve = vdbs_now();
    st = solve(o, solver, quality, &volume, &outputs, report, err);
    report->seconds_solve = vdbs_now() - t_solve;
    if (st != VDBS_OK)
        goto done;
    for (size_t v = 0; v < volume.coord_count; ++v)
        for (int c = 0; c < 3; ++c)
            report->radiance_max[c] = fmaxf(report->radiance_max[c], radiance[3 * v + c]);

    char sky_text[16], solve_text[32], svd_d[16], svd_n[16];
    snprintf(sky_text, sizeof sky_text, "%d", sky);
    snprintf(solve_text, sizeof solve_text, "%.6f", report->seconds_solve);
    snprintf(svd_d, sizeof svd_d, "%d", keep.directions);
    snprintf(svd_n, sizeof svd_n, "%d", keep.terms);
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
        {"vdbscatter_s1", report->s1},
        {"vdbscatter_backend", report->backend},
        {"vdbscatter_solve_seconds", solve_text},
        {"vdbscatter_scene", scene_json},
        /* the last two only with --keep-state */
        {"vdbscatter_svd_directions", svd_d},
        {"vdbscatter_svd_terms", svd_n},
    };
    const vdbio_vec3_grid fixed[] = {
        {"radiance", radiance},       {"ms", outputs.ms},
        {"ms_l1x", outputs.ms_l1[0]}, {"ms_l1y", outputs.ms_l1[1]},
        {"ms_l1z", outputs.ms_l1[2]}, {"radiance_view", outputs.radiance_view},
    };
    /* radiance_view, the last, only with a camera; then the moments */
    const int fixed_count = (int)(sizeof fixed / sizeof fixed[0]) - (outputs.radiance_view ? 0 : 1);
    grids = calloc((size_t)(fixed_count + keep.terms), sizeof *grids);
    names = calloc((size_t)(keep.terms > 0 ? keep.terms : 1), sizeof *names);
    if (!grids || !names) {
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the grid list");
        free(scale);
        free(g);
        goto done;
    }
    memcpy(grids, fixed, sizeof *grids * (size_t)fixed_count);
    for (int k = 0; k < keep.terms; ++k) {
        svd_grid_name(k, names[k], sizeof names[k]);
        grids[fixed_count + k] = (vdbio_vec3_grid){names[k], keep.voxels[k]};
    }
    vdbio_write_request request = {0};
    request.density = volume.density;
    request.coords = volume.coords;
    request.coord_count = volume.coord_count;
    request.vec3_grids = grids;
    request.vec3_grid_count = fixed_count + keep.terms;
    request.file_meta = meta;
    request.file_meta_count = (int)(sizeof meta / sizeof meta[0]) - (keep.terms > 0 ? 0 : 2);
    request.half = o->half;
    request.warn = o->warn;
    request.warn_user = o->warn_user;
    request.cancel = o->cancel;
    double t_write = vdbs_now();
    st = vdbio_write(o->output, input, &request, err);
    report->seconds_write = vdbs_now() - t_write;
    /* A cancel after the rename: the new file is complete and stays, but the caller asked
     * to stop and hears so. */
    if (st == VDBS_OK && vdbs_cancelled(o->cancel))
        st = vdbs_error_cancelled(err);
    free(scale);
    free(g);
done:
    report->seconds_total = vdbs_now() - t_start;
    free(grids);
    free(names);
    vdbs_svd_moments_free(&warm);
    vdbs_svd_moments_free(&keep);
    free(scene_json);
    for (int a = 0; a < 3; ++a)
        if (outputs.ms_l1[a] != outputs.ms)
            free(outputs.ms_l1[a]);
    free(outputs.ms);
    free(outputs.radiance_view);
    free(radiance);
    vdbs_volume_free(&volume);
    free(resolved);
    return st;
}
