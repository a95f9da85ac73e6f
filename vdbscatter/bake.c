#include "vdbscatter/bake.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/advice.h"
#include "vdbscatter/camera_radiance.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/litvdb.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifndef VDBSCATTER_VERSION
#define VDBSCATTER_VERSION "0"
#endif

/* The lit VDB's fixed metadata, the stored lights', then the solver state's. */
#define BAKE_META_FIXED 13
#define BAKE_META_MAX (BAKE_META_FIXED + 2 + 8 + VDBS_BAKE_EXTRA_META_MAX)

/* The optical depths toward every light that --store lights keeps, and their metadata. */
typedef struct stored_lights {
    int direct, count;              /* direct lights, then sky ordinates */
    vdbs_light_grid_samples *depth; /* per light (vdbs_solve.light_depths) */
    char *json;                     /* vdbscatter_lights */
} stored_lights;

static void stored_free(stored_lights *k)
{
    for (int i = 0; k->depth && i < k->count; ++i)
        vdbs_light_grid_samples_free(&k->depth[i]);
    free(k->depth);
    free(k->json);
    memset(k, 0, sizeof *k);
}

static cJSON *json_triple(const double v[3])
{
    const double rounded[3] = {(float)v[0], (float)v[1], (float)v[2]};
    return cJSON_CreateDoubleArray(rounded, 3);
}

/* vdbscatter_lights: per stored grid, what S1 needs to evaluate it (docs/lit-vdb.md). */
static char *stored_lights_json(const vdbs_light_table *lights,
                                const vdbs_light_grid_samples *depth)
{
    cJSON *list = cJSON_CreateArray();
    const double origin[3] = {0.0, 0.0, 0.0};
    for (int i = 0; list && i < lights->direct_count + lights->ordinate_count; ++i) {
        char name[32];
        vdbs_lit_depth_name(i, lights->direct_count, name, sizeof name);
        cJSON *e = cJSON_CreateObject();
        cJSON_AddItemToArray(list, e);
        cJSON_AddStringToObject(e, "grid", name);
        const vdbs_direct_light *d = i < lights->direct_count ? &lights->direct[i] : NULL;
        if (d && d->type == VDBS_LIGHT_POINT) {
            cJSON_AddStringToObject(e, "type", "point");
            cJSON_AddItemToObject(e, "position", json_triple(d->world));
            cJSON_AddItemToObject(e, "intensity", json_triple(d->color));
            cJSON_AddNumberToObject(e, "min_distance", (float)lights->min_distance);
            /* the depth grid's layout: octahedral texels x shells (docs/lit-vdb.md) */
            cJSON_AddNumberToObject(e, "texels", depth[i].texels);
            double *radii = malloc(sizeof *radii * (size_t)(depth[i].shells + 1));
            for (int k = 0; radii && k < depth[i].shells; ++k)
                radii[k] = depth[i].radii[k];
            cJSON_AddItemToObject(e, "radii",
                                  radii ? cJSON_CreateDoubleArray(radii, depth[i].shells)
                                        : cJSON_CreateNull());
            free(radii);
        } else {
            double color[3], travel[3];
            vdbs_lights_arrival(lights, i, origin, color, travel);
            cJSON_AddStringToObject(e, "type", d ? "sun" : "sky");
            cJSON_AddItemToObject(e, "travel", json_triple(travel));
            cJSON_AddItemToObject(e, "radiance", json_triple(color));
        }
    }
    char *text = list ? cJSON_PrintUnformatted(list) : NULL;
    cJSON_Delete(list);
    return text;
}

/* Room for every light's depth, kept by the solve's S1 pass (vdbs_solve.light_depths). */
static vdbs_status stored_alloc(const vdbs_light_table *lights, stored_lights *k, vdbs_error *err)
{
    k->direct = lights->direct_count;
    k->count = lights->direct_count + lights->ordinate_count;
    k->depth = calloc((size_t)k->count + 1, sizeof *k->depth);
    if (!k->depth)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the stored lights");
    return VDBS_OK;
}

static void warn(const vdbs_bake_options *o, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void warn(const vdbs_bake_options *o, const char *fmt, ...)
{
    if (!o->warn)
        return;
    char line[512];
    va_list args;
    va_start(args, fmt);
    vsnprintf(line, sizeof line, fmt, args);
    va_end(args);
    o->warn(o->warn_user, line);
}

const void *vdbs_bake_report_stats(const vdbs_bake_report *report)
{
    return report->solver_stats.bytes;
}

/* ms_l1 = (3 g / 4 pi) integral Lms w dw and ms = (1 / 4 pi) integral Lms dw with Lms >= 0, so
 * |ms_l1| <= 3 |g| ms holds exactly (docs/design.md "output grids"). A solver's moments can
 * break it by rounding or upsampling where ms is near 0 (FLD at 1e4 per voxel: ms 0, |ms_l1|
 * 7e-3); each voxel's ms_l1 is scaled back onto the bound. The true moments satisfy it, so the
 * projection never moves a result away from them. */
static void bound_first_moments(size_t count, double g, const float *ms, float *const l1[3])
{
    for (size_t i = 0; i < 3 * count; ++i) {
        const double x = l1[0][i], y = l1[1][i], z = l1[2][i];
        const double len = sqrt(x * x + y * y + z * z), bound = 3.0 * fabs(g) * ms[i];
        if (len > bound) {
            const double f = bound / len;
            l1[0][i] = (float)(x * f);
            l1[1][i] = (float)(y * f);
            l1[2][i] = (float)(z * f);
        }
    }
}

/* Runs the scene's solver on the chosen backend; the lights are resolved here, once. */
static vdbs_status solve(const vdbs_bake_options *o, const vdbs_solver *solver,
                         const vdbs_quality *quality, const vdbs_volume *volume, vdbs_solve *s,
                         stored_lights *stored, vdbs_bake_report *report, vdbs_error *err)
{
    vdbs_lights_desc lights_desc = {0};
    lights_desc.sky_ordinates = vdbs_solver_sky_directions(solver, o->scene, quality);
    vdbs_light_table lights;
    vdbs_status st = vdbs_lights_build(volume, o->scene, &lights_desc, &lights, err);
    if (st == VDBS_OK && stored)
        st = stored_alloc(&lights, stored, err);
    if (st != VDBS_OK) {
        vdbs_lights_free(&lights);
        return st;
    }
    s->light_depths = stored ? stored->depth : NULL;
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
                                  0, o->s1_sky_spacing};
    s->s1_grids = o->s1_march ? NULL : &grids;
    s->progress = &progress;
    vdbs_s1_stats stats;
    memset(&stats, 0, sizeof stats);
    s->s1_stats = &stats;
    memset(&report->solver_stats, 0, sizeof report->solver_stats);
    st = solver->run(s, report->solver_stats.bytes, err);
    /* A solver that made no S1 pass of its own (or an empty volume) leaves the depths unset:
     * the file then stores none, as with --store none. */
    for (int i = 0; st == VDBS_OK && stored && stored->depth && i < stored->count; ++i)
        if (!stored->depth[i].values)
            stored_free(stored);
    if (st == VDBS_OK && stored && stored->depth &&
        !(stored->json = stored_lights_json(&lights, stored->depth)))
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the stored lights");
    vdbs_runner_transfer moved = vdbs_runner_transfers(runner);
    report->bytes_uploaded = moved.uploaded;
    report->bytes_read_back = moved.read_back;
    if (st == VDBS_OK && solver->writes_ms)
        bound_first_moments(volume->coord_count, o->scene->g, s->ms, s->ms_l1);
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
    memcpy(report->s1_kinds, stats.kinds, sizeof report->s1_kinds);
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
    const vdbs_quality *quality = vdbs_solver_quality(solver, vdbs_quality_find(o->scene->quality));
    if (!solver || !quality)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown method '%s' or quality '%s'",
                              o->scene->method, o->scene->quality);
    vdbs_solve s = {0};
    s.radiance = radiance;
    s.ms = ms;
    for (int a = 0; a < 3; ++a)
        s.ms_l1[a] = ms_l1[a];
    double t0 = vdbs_now();
    vdbs_status st = solve(o, solver, quality, volume, &s, NULL, report, err);
    report->seconds_solve = report->seconds_total = vdbs_now() - t0;
    return st;
}

/* ---- the bake of a file, step by step ---- */

/* What a bake holds between its steps; job_free releases it. */
typedef struct bake_job {
    vdbs_bake_options options; /* the caller's, with the scene as resolved */
    const vdbs_solver *solver;
    const vdbs_quality *quality;
    const char *input;
    int sky;
    vdbs_volume volume;
    int has_volume;
    vdbs_scene *scene; /* the caller's, resolved against the volume (auto density scale) */
    void *warm, *keep; /* the solver's state: read by --warm-start, written by --keep-state */
    vdbs_solve out;    /* the output arrays */
    stored_lights stored;
    char *scene_json;
    char *plan_json; /* --method auto */
} bake_job;

static void job_free(bake_job *j)
{
    const vdbs_solver_state *state = j->solver ? j->solver->state : NULL;
    if (state && state->destroy) {
        state->destroy(j->warm);
        state->destroy(j->keep);
    }
    free(j->scene_json);
    free(j->plan_json);
    stored_free(&j->stored);
    for (int a = 0; a < 3; ++a)
        if (j->out.ms_l1[a] != j->out.ms)
            free(j->out.ms_l1[a]);
    free(j->out.ms);
    free(j->out.radiance_view);
    free(j->out.radiance);
    if (j->has_volume)
        vdbs_volume_free(&j->volume);
    free(j->scene);
}

/* The request's checks that need no file: input, method, state flags, output, quality. */
static vdbs_status check_request(bake_job *j, vdbs_error *err)
{
    const vdbs_bake_options *o = &j->options;
    const vdbs_scene *scene = o->scene;
    j->input = o->input ? o->input : scene->volume_file;
    if (!j->input || !j->input[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT, "no input volume given");
    j->solver = vdbs_solver_find(scene->method);
    if (!j->solver) {
        char names[256];
        vdbs_solver_names(names, sizeof names);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--method %s is not implemented yet (available: %s)", scene->method,
                              names);
    }
    if (o->tolerance > 0.0 && (o->keep_state || o->warm_start))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s needs a fixed --method, not auto",
                              o->keep_state ? "--keep-state" : "--warm-start");
    if ((o->keep_state || o->warm_start) && !j->solver->state)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s needs a method that keeps state (--method %s keeps none)",
                              o->keep_state ? "--keep-state" : "--warm-start", j->solver->name);
    vdbs_status st = j->solver->check ? j->solver->check(scene, err) : VDBS_OK;
    if (st == VDBS_OK)
        st = vdbio_check_output(o->output, j->input, err);
    if (st != VDBS_OK)
        return st;
    j->quality = vdbs_solver_quality(j->solver, vdbs_quality_find(scene->quality));
    if (!j->quality)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown quality '%s'", scene->quality);
    j->sky = vdbs_solver_sky_directions(j->solver, scene, j->quality);
    for (int i = 0; i < scene->light_count; ++i)
        if (scene->lights[i].type == VDBS_LIGHT_SUN && scene->lights[i].angular_diameter_deg > 0)
            warn(o, "sun angular_diameter_deg is treated as 0 (a delta light) by --method "
                    "single");
    return vdbs_cancelled(o->cancel) ? vdbs_error_cancelled(err) : VDBS_OK;
}

/* The volume, and the scene resolved against it (auto density scale; a light is needed). */
static vdbs_status load(bake_job *j, vdbs_bake_report *report, vdbs_error *err)
{
    const vdbs_bake_options *o = &j->options;
    vdbio_read_options read = {0};
    read.grid_name = o->scene->grid[0] ? o->scene->grid : NULL;
    read.grid_index = o->scene->grid_index;
    read.from_levelset = o->from_levelset;
    read.warn = o->warn;
    read.warn_user = o->warn_user;
    vdbs_status st = vdbs_volume_load(j->input, &read, &j->volume, err);
    if (st != VDBS_OK)
        return st;
    j->has_volume = 1;
    if (!(j->scene = malloc(sizeof *j->scene)))
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    *j->scene = *o->scene;
    j->options.scene = j->scene;
    /* The scene recorded in the report and the lit VDB names the volume baked, also when the
     * caller's input overrides the scene file's. The volume was opened from that path, so it
     * is shorter than PATH_MAX, the field's size: the copy is whole. */
    if (j->input != o->scene->volume_file)
        snprintf(j->scene->volume_file, sizeof j->scene->volume_file, "%s", j->input);
    if ((st = vdbs_scene_fit_density(j->scene, &j->volume, err)) != VDBS_OK)
        return st;
    if (j->scene->light_count == 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s", VDBS_NO_LIGHT_MESSAGE);
    report->density_scale = j->scene->density_scale;
    vdbs_scene_advise(j->scene, &j->volume, j->solver->writes_ms, o->warn, o->warn_user,
                      &report->advice);
    return VDBS_OK;
}

/* --method auto: the plan for the scene on its volume, applied to the job's scene. */
static vdbs_status plan(bake_job *j, vdbs_bake_report *report, vdbs_error *err)
{
    const vdbs_bake_options *o = &j->options;
    vdbs_status st = vdbs_plan_measure(j->scene, &j->volume, &report->plan_features, err);
    if (st == VDBS_OK)
        st = vdbs_plan_make(&report->plan_features,
                            &(vdbs_plan_desc){o->tolerance, o->plan_leave_out}, &report->plan, err);
    if (st != VDBS_OK)
        return st;
    report->planned = 1;
    const vdbs_plan *p = &report->plan;
    int count;
    const vdbs_quality *q = &vdbs_quality_list(&count)[p->chosen.quality];
    /* Out of reach, the bake still gives the best the planner expects, and says so: a farm job
     * gets a picture and a line (and the report's and metadata's reachable false) rather than a
     * failed frame. */
    if (!p->reachable && !o->dry_run)
        warn(o,
             "--tolerance %g is out of reach on this scene: baking the most accurate plan, "
             "predicted %.3g (--method %s --quality %s, cost hint %.0f s)",
             o->tolerance, p->chosen.error, p->chosen.method, q->name, p->chosen.seconds);
    if ((st = vdbs_plan_apply(p, j->scene, err)) != VDBS_OK)
        return st;
    if (!(j->plan_json = vdbs_plan_json(p, &report->plan_features)))
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    j->solver = vdbs_solver_find(j->scene->method);
    j->quality = vdbs_solver_quality(j->solver, q);
    j->sky = vdbs_solver_sky_directions(j->solver, j->scene, j->quality);
    return VDBS_OK;
}

/* --warm-start's state read, --keep-state's created empty. */
static vdbs_status open_state(bake_job *j, vdbs_error *err)
{
    const vdbs_solver_state *state = j->solver->state;
    const vdbs_bake_options *o = &j->options;
    vdbs_status st = VDBS_OK;
    if (o->warm_start)
        st = state->read(o->warm_start, &j->volume, j->scene, &j->warm, err);
    if (st == VDBS_OK && o->keep_state && !(j->keep = state->create()))
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the solver's state");
    if (st == VDBS_OK && vdbs_cancelled(o->cancel))
        st = vdbs_error_cancelled(err);
    return st;
}

/* The output voxels the arrays are sized for (one for an empty volume). */
static size_t output_voxels(const bake_job *j)
{
    return j->volume.coord_count ? j->volume.coord_count : 1;
}

/* `arrays` arrays of 3 floats per output voxel, in bytes. */
static int64_t voxel_arrays_bytes(const bake_job *j, int arrays)
{
    return arrays * 3 * (int64_t)output_voxels(j) * (int64_t)sizeof(float);
}

/* The output arrays' bytes (alloc_outputs). */
static int64_t outputs_bytes(const bake_job *j)
{
    return voxel_arrays_bytes(j, 2 + (j->solver->writes_ms ? 3 : 0) +
                                     (j->scene->camera.present ? 1 : 0));
}

/* A stored depth sample: its (i, j, k) and value (vdbs_light_grid_samples). */
#define STORED_SAMPLE_BYTES (3 * (int64_t)sizeof(int32_t) + (int64_t)sizeof(float))

/* --max-memory: the bake's estimate from the sizes each stage allocates, checked before the
 * outputs and the solve allocate. The solve holds the outputs, the stored depths and the S1
 * pass (one light grid at a time); the write the outputs, the stored depths and OpenVDB's
 * trees of them. Solvers' coarse grids are bounded by their resolution, not the volume's,
 * and are not counted (docs/robustness.md). */
static vdbs_status check_memory(bake_job *j, vdbs_bake_report *report, vdbs_error *err)
{
    const vdbs_bake_options *o = &j->options;
    report->memory_limit = o->max_memory > 0    ? o->max_memory
                           : o->max_memory == 0 ? vdbs_memory_default_limit()
                                                : 0;
    report->memory_baseline = vdbs_memory_rss();
    vdbs_memory_estimate *e = &report->memory_estimate;
    memset(e, 0, sizeof *e);
    vdbs_lights_desc lights_desc = {0};
    lights_desc.sky_ordinates = j->sky;
    vdbs_light_table lights;
    vdbs_status st = vdbs_lights_build(&j->volume, j->scene, &lights_desc, &lights, err);
    if (st != VDBS_OK)
        return st;
    const int count = lights.direct_count + lights.ordinate_count;
    const int oversample =
        report->s1_oversample > 0 ? report->s1_oversample : VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
    vdbs_light_grid_desc grids = {oversample, 0, o->s1_sky_spacing};
    /* the march keeps no grid, but its second pass for the camera or the stored depths does
     * at the default oversample (vdbs_solve_s1) */
    if (o->s1_march)
        grids.oversample = VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
    vdbs_light_grids_memory lg;
    st = vdbs_light_grids_estimate(&j->volume, &lights, 0, count, &grids, &lg, err);
    vdbs_lights_free(&lights);
    if (st != VDBS_OK)
        return st;
    const int store = o->store != VDBS_STORE_NONE;
    const int64_t stored = store ? lg.samples : 0;
    vdbs_memory_add(e, "outputs", outputs_bytes(j));
    vdbs_memory_add(e, "stored depths", stored * STORED_SAMPLE_BYTES);
    /* --keep-state's arrays, filled by the solve and written with the outputs (a warm start's
     * were read before: the baseline holds them) */
    const vdbs_solver_state *state = j->solver->state;
    const int kept = j->keep && state->arrays ? state->arrays(j->scene, j->warm) : 0;
    if (kept > 0)
        vdbs_memory_add(e, "kept state", voxel_arrays_bytes(j, kept));
    int64_t s1 =
        vdbs_single_scatter_grids_bytes(&j->volume, j->scene->camera.present) + lg.peak_one;
    /* write_lit writes radiance, ms and the three l1 grids (shared zeros or not), the view and
     * the kept state's grids */
    int vec3 = 5 + (j->scene->camera.present ? 1 : 0) + kept;
    int64_t nodes[3];
    vdbs_volume_node_counts(&j->volume, nodes);
    int64_t write = vdbio_write_bytes(nodes, vec3, store ? count : 0, stored);
    /* the solver's own arrays live beside the S1 pass's */
    const int64_t solver =
        j->solver->solve_bytes ? j->solver->solve_bytes(j->scene, output_voxels(j)) : 0;
    if (s1 + solver >= write) {
        vdbs_memory_add(e, "light grids", s1);
        if (solver > 0)
            vdbs_memory_add(e, "solver", solver);
    } else {
        vdbs_memory_add(e, "write", write);
    }
    char what[160];
    snprintf(what, sizeof what, "%d light%s at --quality %s, --s1-oversample %d%s", count,
             count == 1 ? "" : "s", j->scene->quality, grids.oversample,
             store ? ", --store lights" : "");
    if (kept > 0)
        snprintf(what + strlen(what), sizeof what - strlen(what), ", --keep-state %d grids", kept);
    const char *flags = solver > 0 ? j->solver->solve_bytes_flags : NULL;
    char lower[128];
    snprintf(lower, sizeof lower, "--quality, --s1-oversample%s%s%s%s",
             store ? ", --store none" : "", kept > 0 ? ", --keep-state" : "", flags ? ", " : "",
             flags ? flags : "");
    vdbs_memory_estimate all = *e;
    vdbs_memory_add(&all, "loaded", report->memory_baseline);
    return vdbs_memory_check(&all, report->memory_limit,
                             o->max_memory > 0 ? "--max-memory" : VDBS_MEMORY_DEFAULT_SOURCE, what,
                             lower, err);
}

/* Zeroed output arrays; without multiple scattering the four ms grids are one. */
static vdbs_status alloc_outputs(bake_job *j, vdbs_error *err)
{
    size_t n = output_voxels(j);
    vdbs_solve *out = &j->out;
    out->radiance = calloc(3 * n, sizeof(float));
    out->ms = calloc(3 * n, sizeof(float));
    for (int a = 0; a < 3; ++a)
        out->ms_l1[a] = j->solver->writes_ms ? calloc(3 * n, sizeof(float)) : out->ms;
    if (j->scene->camera.present)
        out->radiance_view = calloc(3 * n, sizeof(float));
    j->scene_json = vdbs_scene_to_json(j->scene);
    if (!out->radiance || !out->ms || !out->ms_l1[0] || !out->ms_l1[1] || !out->ms_l1[2] ||
        (j->scene->camera.present && !out->radiance_view) || !j->scene_json)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu output voxels", n);
    out->warm = j->warm;
    out->keep = j->keep;
    return VDBS_OK;
}

/* The lit VDB: density, the output grids, the solver's state grids, and the metadata. */
static vdbs_status write_lit(bake_job *j, vdbs_bake_report *report, vdbs_error *err)
{
    const vdbs_bake_options *o = &j->options;
    const vdbs_scene *scene = j->scene;
    char sky[16], seconds[32], scale[32], g[32], albedo[96], format[16];
    snprintf(sky, sizeof sky, "%d", j->sky);
    snprintf(format, sizeof format, "%d", VDBS_LIT_FORMAT);
    snprintf(seconds, sizeof seconds, "%.6f", report->seconds_solve);
    /* 17 digits: exact, and the text lit VDBs have always carried */
    snprintf(scale, sizeof scale, "%.17g", scene->density_scale);
    snprintf(g, sizeof g, "%.17g", scene->g);
    snprintf(albedo, sizeof albedo, "%.9g,%.9g,%.9g", scene->albedo[0], scene->albedo[1],
             scene->albedo[2]);
    vdbio_meta meta[BAKE_META_MAX] = {
        {"vdbscatter_version", VDBSCATTER_VERSION},
        {"vdbscatter_method", scene->method},
        {"vdbscatter_quality", scene->quality},
        {"vdbscatter_sky_directions", sky},
        {"vdbscatter_density_scale", scale},
        {"vdbscatter_albedo", albedo},
        {"vdbscatter_g", g},
        {"vdbscatter_s1", report->s1},
        {"vdbscatter_backend", report->backend},
        {"vdbscatter_solve_seconds", seconds},
        {"vdbscatter_scene", j->scene_json},
        {"vdbscatter_format", format},
        {"vdbscatter_store", j->stored.depth ? "lights" : "none"},
    };
    const vdbs_solver_state *state = j->solver->state;
    int meta_count = BAKE_META_FIXED;
    if (j->stored.json)
        meta[meta_count++] = (vdbio_meta){"vdbscatter_lights", j->stored.json};
    if (j->plan_json)
        meta[meta_count++] = (vdbio_meta){"vdbscatter_plan", j->plan_json};
    if (j->keep)
        meta_count += state->meta(j->keep, meta + meta_count,
                                  BAKE_META_MAX - VDBS_BAKE_EXTRA_META_MAX - meta_count);
    for (int i = 0; i < o->extra_meta_count && i < VDBS_BAKE_EXTRA_META_MAX; ++i)
        meta[meta_count++] = o->extra_meta[i];
    const vdbio_vec3_grid fixed[] = {
        {"radiance", j->out.radiance}, {"ms", j->out.ms},
        {"ms_l1x", j->out.ms_l1[0]},   {"ms_l1y", j->out.ms_l1[1]},
        {"ms_l1z", j->out.ms_l1[2]},   {"radiance_view", j->out.radiance_view},
    };
    /* radiance_view, the last, only with a camera; then the state's grids */
    const int fixed_count = (int)(sizeof fixed / sizeof fixed[0]) - (j->out.radiance_view ? 0 : 1);
    const int state_max = j->keep ? state->grids(j->keep, NULL, 0) : 0;
    vdbio_vec3_grid *grids = calloc((size_t)(fixed_count + state_max), sizeof *grids);
    if (!grids)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the grid list");
    memcpy(grids, fixed, sizeof *grids * (size_t)fixed_count);
    const int state_count = j->keep ? state->grids(j->keep, grids + fixed_count, state_max) : 0;
    if (state_count < 0) {
        free(grids);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the state's grid names");
    }
    /* The stored depths: the sky's many ordinates as half floats (a depth's relative rounding
     * of 2^-11 moves exp(-depth) by at most 2^-11 depth exp(-depth) < 2e-4), the few direct
     * lights as floats. */
    vdbio_float_grid *depths = calloc((size_t)j->stored.count + 1, sizeof *depths);
    char(*names)[32] = calloc((size_t)j->stored.count + 1, sizeof *names);
    vdbio_transform *maps = calloc((size_t)j->stored.count + 1, sizeof *maps);
    if (!depths || !names || !maps) {
        free(depths);
        free(names);
        free(maps);
        free(grids);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the grid list");
    }
    for (int i = 0; i < j->stored.count; ++i) {
        const vdbs_light_grid_samples *d = &j->stored.depth[i];
        vdbs_lit_depth_name(i, j->stored.direct, names[i], sizeof names[i]);
        /* the grid's index space -> the density's -> world */
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) {
                double m = c == 3 ? j->volume.index_to_world[r][3] : 0.0;
                for (int q = 0; q < 3; ++q)
                    m += j->volume.index_to_world[r][q] * d->to_index[q][c];
                maps[i].m[r][c] = m;
            }
        depths[i] = (vdbio_float_grid){.name = names[i],
                                       .values = d->values,
                                       .coords = d->coords,
                                       .coord_count = d->count,
                                       .transform = &maps[i],
                                       .half = i >= j->stored.direct};
    }
    vdbio_write_request request = {0};
    request.float_grids = depths;
    request.float_grid_count = j->stored.count;
    request.density = j->volume.density;
    request.coords = j->volume.coords;
    request.coord_count = j->volume.coord_count;
    request.vec3_grids = grids;
    request.vec3_grid_count = fixed_count + state_count;
    request.file_meta = meta;
    request.file_meta_count = meta_count;
    request.half = o->half;
    request.warn = o->warn;
    request.warn_user = o->warn_user;
    request.cancel = o->cancel;
    double t_write = vdbs_now();
    vdbs_status st = vdbio_write(o->output, j->input, &request, err);
    report->seconds_write = vdbs_now() - t_write;
    free(grids);
    free(depths);
    free(names);
    free(maps);
    /* A cancel after the rename: the new file is complete and stays, but the caller asked
     * to stop and hears so. */
    if (st == VDBS_OK && vdbs_cancelled(o->cancel))
        st = vdbs_error_cancelled(err);
    return st;
}

/* The report's facts about the volume and the S1 pass, known before the solve. */
static void report_setup(const bake_job *j, vdbs_bake_report *report)
{
    const vdbs_bake_options *o = &j->options;
    snprintf(report->grid, sizeof report->grid, "%s", j->volume.info.name);
    report->active_voxels = j->volume.info.active_voxels;
    report->output_voxels = j->volume.coord_count;
    report->sky_directions = j->sky;
    snprintf(report->s1, sizeof report->s1, "%s", o->s1_march ? "march" : "grid");
    snprintf(report->quality_baked, sizeof report->quality_baked, "%s", j->quality->name);
    report->s1_oversample = o->s1_march            ? 0
                            : o->s1_oversample > 0 ? o->s1_oversample
                                                   : j->quality->s1_oversample;
}

/* A stage's line in a farm's log (progress.h; nothing on a terminal): said when the stage is
 * done, so that input refused while loading says nothing but its error. */
static void stage_done(const vdbs_bake_options *o, const char *stage, double seconds,
                       const char *detail)
{
    if (!o->progress)
        return;
    char text[256], fields[96];
    snprintf(text, sizeof text, "done in %.2fs%s%s", seconds, detail[0] ? ", " : "", detail);
    snprintf(fields, sizeof fields, "\"seconds\": %.3f", seconds);
    vdbs_progress_event("stage", stage, text, fields);
}

vdbs_status vdbs_bake(const vdbs_bake_options *o, vdbs_bake_report *report, vdbs_error *err)
{
    memset(report, 0, sizeof *report);
    double t_start = vdbs_now();
    bake_job j;
    memset(&j, 0, sizeof j);
    j.options = *o;
    vdbs_status st = check_request(&j, err);
    if (st == VDBS_OK)
        st = load(&j, report, err);
    if (st == VDBS_OK && o->tolerance > 0.0)
        st = plan(&j, report, err);
    if (st == VDBS_OK && o->tolerance > 0.0 && o->dry_run) {
        report_setup(&j, report);
        report->seconds_total = vdbs_now() - t_start;
        job_free(&j);
        return VDBS_OK;
    }
    if (st == VDBS_OK && j.solver->state)
        st = open_state(&j, err);
    if (st == VDBS_OK) {
        report->seconds_load = vdbs_now() - t_start;
        report_setup(&j, report);
        st = check_memory(&j, report, err);
    }
    if (st == VDBS_OK) {
        char detail[96];
        snprintf(detail, sizeof detail, "%llu active voxels", report->active_voxels);
        stage_done(o, "load", report->seconds_load, detail);
    }
    if (st == VDBS_OK) {
        report->peak_load = vdbs_memory_peak();
        report->peak_per_stage = vdbs_memory_reset_peak();
        st = alloc_outputs(&j, err);
    }
    if (st == VDBS_OK) {
        double t_solve = vdbs_now();
        st = solve(&j.options, j.solver, j.quality, &j.volume, &j.out,
                   o->store == VDBS_STORE_NONE ? NULL : &j.stored, report, err);
        report->seconds_solve = vdbs_now() - t_solve;
        report->peak_solve = vdbs_memory_peak();
        report->peak_per_stage &= vdbs_memory_reset_peak();
        if (st == VDBS_OK) {
            char label[64];
            snprintf(label, sizeof label, "solve %s", j.solver->name);
            stage_done(o, label, report->seconds_solve, "");
        }
    }
    if (st == VDBS_OK) {
        for (size_t v = 0; v < j.volume.coord_count; ++v)
            for (int c = 0; c < 3; ++c)
                report->radiance_max[c] = fmaxf(report->radiance_max[c], j.out.radiance[3 * v + c]);
        report->stored_direct = j.stored.direct;
        report->stored_sky = j.stored.count - j.stored.direct;
        st = write_lit(&j, report, err);
        report->peak_write = vdbs_memory_peak();
        if (st == VDBS_OK)
            stage_done(o, "write", report->seconds_write, o->output ? o->output : "");
    }
    if (j.has_volume)
        report->seconds_total = vdbs_now() - t_start;
    job_free(&j);
    return st;
}
