#include "vdbscatter/render.h"

#include "vdbscatter/advice.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/scene_file.h"

int vdbs_render_quality(const char *quality, vdbs_march_options *options)
{
    const vdbs_quality *q = vdbs_quality_find(quality);
    if (!q)
        return 0;
    options->sky_directions = q->sky_directions;
    options->step_voxels = q->render_step_voxels;
    options->s1_oversample = q->s1_oversample;
    return 1;
}

vdbs_status vdbs_render_march(vdbs_runner *runner, const vdbs_volume *volume,
                              const vdbs_lit_grids *ms, const vdbs_scene *scene,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              vdbs_image *image, vdbs_error *err)
{
    vdbs_march_session *session = NULL;
    vdbs_status st;
    if ((st = vdbs_march_session_create(runner, volume, ms, scene, options, &session, err)) !=
        VDBS_OK)
        return st;
    /* Between the light grids and the camera rays (which poll it themselves). */
    st = vdbs_progress_cancelled(options->progress)
             ? vdbs_error_cancelled(err)
             : vdbs_march_session_draw(session, frame, options, image, err);
    vdbs_march_session_destroy(session);
    return st;
}

/* ---- the render job ---- */

static const char *const mode_names[] = {NULL, "single", "baked", "reference"};

const char *vdbs_render_mode_name(vdbs_render_mode mode)
{
    return mode >= VDBS_RENDER_SINGLE && mode <= VDBS_RENDER_REFERENCE ? mode_names[mode] : NULL;
}

static void warn(const vdbs_render_desc *d, const char *message)
{
    if (d->warn)
        d->warn(d->warn_user, message);
}

/* The scene of a lit VDB: its baked scene with the caller's explicit settings on top. */
static void apply_overrides(unsigned set, const vdbs_scene *given, vdbs_scene *scene)
{
    if (set & VDBS_SCENE_SET_DENSITY_SCALE) {
        scene->density_scale = given->density_scale;
        scene->density_target_depth = given->density_target_depth;
    }
    if (set & VDBS_SCENE_SET_ALBEDO)
        memcpy(scene->albedo, given->albedo, sizeof scene->albedo);
    if (set & VDBS_SCENE_SET_G)
        scene->g = given->g;
    if (set & VDBS_SCENE_SET_QUALITY) {
        memcpy(scene->quality, given->quality, sizeof scene->quality);
        scene->sky_directions = given->sky_directions; /* the quality's K unless also given */
    }
    if (set & VDBS_SCENE_SET_SKY_DIRECTIONS)
        scene->sky_directions = given->sky_directions;
    if (set & VDBS_SCENE_SET_LIGHTS)
        vdbs_scene_copy_lights(scene, given);
    if (set & VDBS_SCENE_SET_GRID) {
        memcpy(scene->grid, given->grid, sizeof scene->grid);
        scene->grid_index = given->grid_index;
    }
}

static int same_triple(const double a[3], const double b[3])
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

/* Whether two scenes have the same medium and lights (what a lit VDB was baked with). */
static int same_lighting(const vdbs_scene *a, const vdbs_scene *b)
{
    /* A lit VDB's scene holds its resolved scale; a file's auto:TAU is resolved against the
     * lit VDB's own density once it is loaded, and compared then (vdbs_render_open). */
    const int same_scale = (b->density_target_depth > 0.0 && a->density_target_depth == 0.0) ||
                           (a->density_scale == b->density_scale &&
                            a->density_target_depth == b->density_target_depth);
    if (!same_scale || !same_triple(a->albedo, b->albedo) || a->g != b->g ||
        a->light_count != b->light_count || a->sky_directions != b->sky_directions ||
        strcmp(a->grid, b->grid) != 0)
        return 0;
    for (int i = 0; i < a->light_count; ++i) {
        const vdbs_light *p = &a->lights[i], *q = &b->lights[i];
        const char *fp = vdbs_light_env_file(a, p), *fq = vdbs_light_env_file(b, q);
        if (p->type != q->type || !same_triple(p->direction, q->direction) ||
            !same_triple(p->position, q->position) || !same_triple(p->color, q->color) ||
            p->angular_diameter_deg != q->angular_diameter_deg || p->env_scale != q->env_scale ||
            (fp == NULL) != (fq == NULL) || (fp && strcmp(fp, fq) != 0))
            return 0;
    }
    return 1;
}

/* A baked render shows the lit VDB as baked: settings that change its lights or medium
 * would leave its multiple scattering stale, so they need --relight. */
static vdbs_status check_unchanged(const vdbs_render_desc *d, const vdbs_scene *baked,
                                   const vdbs_scene *scene, vdbs_error *err)
{
    static const struct {
        unsigned bit;
        const char *flags;
    } changes[] = {
        {VDBS_SCENE_SET_DENSITY_SCALE, "--density-scale"},
        {VDBS_SCENE_SET_ALBEDO, "--albedo"},
        {VDBS_SCENE_SET_G, "--g"},
        {VDBS_SCENE_SET_LIGHTS, "--sun, --point and --env"},
        {VDBS_SCENE_SET_SKY_DIRECTIONS, "--sky-directions"},
        {VDBS_SCENE_SET_GRID, "--grid"},
    };
    for (size_t i = 0; i < sizeof changes / sizeof changes[0]; ++i)
        if (d->scene_set & changes[i].bit)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "%s change%s the lights or medium the lit VDB was baked with; "
                                  "add --relight to relight it (its multiple scattering stays "
                                  "as baked)",
                                  changes[i].flags, strchr(changes[i].flags, ',') ? "" : "s");
    if ((d->scene_set & VDBS_SCENE_FROM_FILE) && !same_lighting(baked, scene))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--scene: its lights or medium differ from the ones the lit VDB "
                              "was baked with; add --relight to relight it (its multiple "
                              "scattering stays as baked)");
    return VDBS_OK;
}

/* Opens the input: a lit VDB brings its baked scene (*is_lit), and the render scene is
 * resolved from it and the caller's. On success *lit is open (the caller closes it), and
 * *baked_scale is the scale the scene's auto:TAU must resolve to (a scene file on a lit VDB in
 * baked mode), else 0. */
static vdbs_status resolve_scene(const vdbs_render_desc *d, const char *input, vdbio_lit **lit,
                                 vdbs_render_mode *mode, int *is_lit, vdbs_scene *scene,
                                 char baked_method[32], double *baked_scale, vdbs_error *err)
{
    *baked_scale = 0.0;
    vdbs_status st = vdbio_lit_open(input, lit, err);
    if (st != VDBS_OK)
        return st;
    if (d->relight && d->mode != VDBS_RENDER_DEFAULT && d->mode != VDBS_RENDER_BAKED)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--relight applies to --mode baked only");
    const char *meta = vdbio_lit_meta(*lit, "vdbscatter_scene");
    *is_lit = meta && vdbio_lit_has_grid(*lit, "radiance") && vdbio_lit_has_grid(*lit, "density");
    vdbs_scene *baked = malloc(sizeof *baked);
    if (!baked)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    if (*is_lit && (st = vdbs_scene_parse(meta, NULL, baked, err)) != VDBS_OK) {
        vdbs_error inner = *err;
        free(baked);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: vdbscatter_scene metadata: %s", input,
                              inner.message);
    }
    *mode = d->mode != VDBS_RENDER_DEFAULT ? d->mode
            : *is_lit                      ? VDBS_RENDER_BAKED
                                           : VDBS_RENDER_SINGLE;
    if (*mode == VDBS_RENDER_BAKED && !*is_lit) {
        free(baked);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--mode baked needs a lit VDB written by vdbscatter bake ('%s' has "
                              "no radiance grid and vdbscatter_scene metadata)",
                              input);
    }
    if (*is_lit)
        snprintf(baked_method, 32, "%s", baked->method);
    /* A scene file replaces the baked scene; flags alone go on top of it. */
    if (*is_lit && !(d->scene_set & VDBS_SCENE_FROM_FILE)) {
        *scene = *baked;
        apply_overrides(d->scene_set, d->scene, scene);
    } else {
        *scene = *d->scene;
        if (*is_lit && scene->light_count == 0)
            vdbs_scene_copy_lights(scene, baked);
        /* A file that leaves the sky's ordinates to the quality keeps the baked ones (the bake
         * may have had --sky-directions on top of this very file). */
        if (*is_lit && scene->sky_directions == 0)
            scene->sky_directions = baked->sky_directions;
    }
    if (*is_lit && *mode == VDBS_RENDER_BAKED && !d->relight) {
        st = check_unchanged(d, baked, scene, err);
        if (scene->density_target_depth > 0.0)
            *baked_scale = baked->density_scale;
    }
    free(baked);
    if (st != VDBS_OK)
        return st;
    /* No light is reported after the density grid is found (vdbs_render_open). */
    return vdbs_scene_validate_opt(scene, 1, err);
}

/* Camera: the caller's, else the scene's, else a view of the whole volume. */
static void choose_camera(const vdbs_render_desc *d, const vdbs_scene *scene,
                          const vdbs_volume *volume, vdbs_camera *camera)
{
    int width = d->width > 0 ? d->width : 640, height = d->height > 0 ? d->height : 480;
    if (d->camera && d->camera->present) {
        *camera = *d->camera;
    } else if (scene->camera.present) {
        *camera = scene->camera;
        if (!(d->width > 0)) {
            width = camera->width;
            height = camera->height;
        }
    } else {
        vdbs_camera_frame_volume(volume, width, height, camera);
    }
    camera->width = width;
    camera->height = height;
}

static vdbs_status render_image(const vdbs_render_desc *d, vdbs_render_mode mode,
                                const vdbs_volume *volume, const vdbs_lit_grids *ms,
                                const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                vdbs_march_options *march, vdbs_image *image,
                                vdbs_render_report *report, vdbs_error *err)
{
    vdbs_progress progress = {0};
    progress.cancel = d->cancel;
    uint64_t pixels = (uint64_t)frame->width * (uint64_t)frame->height;
    vdbs_status st;
    if (mode == VDBS_RENDER_REFERENCE) {
        vdbs_reference_options ro = {0};
        ro.spp = d->spp > 0 ? d->spp : d->tolerance > 0.0 ? 16 : d->time_limit > 0.0 ? 4 : 64;
        ro.time_limit = d->time_limit;
        ro.tolerance = d->tolerance;
        ro.max_bounces = d->max_bounces > 0 ? d->max_bounces : 1000;
        ro.seed = d->seed;
        ro.no_env_nee = d->no_env_nee;
        ro.progress = &progress;
        snprintf(report->backend, sizeof report->backend, "cpu");
        snprintf(report->renderer, sizeof report->renderer, "C (OpenMP, %d threads)",
                 omp_get_max_threads());
        vdbs_progress_begin(&progress, d->progress, "render (reference)",
                            pixels * (uint64_t)ro.spp);
        st = vdbs_reference_render(volume, scene, frame, &ro, image, &report->spp, err);
        report->noise = vdbs_image_noise(image);
    } else {
        vdbs_runner_desc rd = {.backend = d->backend};
        vdbs_runner *runner = NULL;
        if ((st = vdbs_runner_create(&rd, &runner, err)) != VDBS_OK)
            return st;
        snprintf(report->backend, sizeof report->backend, "%s", vdbs_runner_backend_name(runner));
        snprintf(report->renderer, sizeof report->renderer, "%s", vdbs_runner_device(runner));
        march->progress = &progress;
        march->gpu_units = d->gpu_units;
        march->s1_march = d->s1_march;
        if (d->s1_oversample > 0)
            march->s1_oversample = d->s1_oversample;
        march->stats = &report->march_stats;
        snprintf(report->s1, sizeof report->s1, "%s",
                 march->stored_depths ? "stored"
                 : d->s1_march        ? "march"
                                      : "grid");
        report->s1_oversample = d->s1_march || march->stored_depths ? 0
                                : march->s1_oversample > 0          ? march->s1_oversample
                                                           : VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
        report->spp = 1;
        vdbs_progress_begin(&progress, d->progress, "render", pixels);
        st = vdbs_render_march(runner, volume, mode == VDBS_RENDER_BAKED ? ms : NULL, scene, frame,
                               march, image, err);
        vdbs_runner_destroy(runner);
    }
    if (st == VDBS_OK)
        vdbs_progress_end(&progress);
    return st;
}

/* The VDB a render reads: the desc's, else its scene's volume file. */
static vdbs_status input_path(const vdbs_render_desc *d, const char **input, vdbs_error *err)
{
    *input = d->input ? d->input : d->scene->volume_file;
    if (!*input || !(*input)[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "no input VDB (give IN.vdb or volume.file in --scene)");
    return VDBS_OK;
}

/* S1 from the lit VDB's stored depths: its sky ordinates are the ones it was baked with. */
static vdbs_status use_stored(const vdbs_render_desc *d, vdbs_render_input *in, vdbs_error *err)
{
    if (d->s1_march || d->s1_oversample > 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--s1 applies to --relight: this lit VDB stores the optical depths "
                              "to its lights");
    in->stored = 1;
    in->march.stored_depths = 1;
    int sky = in->ms.depth_count - in->ms.depth_direct;
    if (sky > 0)
        in->march.sky_directions = sky;
    return VDBS_OK;
}

vdbs_status vdbs_render_open(const vdbs_render_desc *d, vdbs_render_input *in, vdbs_error *err)
{
    memset(in, 0, sizeof *in);
    const char *input = NULL;
    vdbs_status st = input_path(d, &input, err);
    if (st != VDBS_OK)
        return st;
    in->scene = malloc(sizeof *in->scene);
    if (!in->scene)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    vdbio_lit *lit = NULL;
    double baked_scale = 0.0;
    st = resolve_scene(d, input, &lit, &in->mode, &in->is_lit, in->scene, in->baked_method,
                       &baked_scale, err);
    if (st == VDBS_OK) {
        for (int i = 0; i < in->scene->light_count; ++i)
            if (in->scene->lights[i].type == VDBS_LIGHT_SUN &&
                in->scene->lights[i].angular_diameter_deg > 0) {
                warn(d, "sun angular_diameter_deg is treated as 0 (a delta light)");
                break;
            }
        if (in->mode == VDBS_RENDER_REFERENCE && d->backend == VDBS_BACKEND_GPU)
            warn(d, "--mode reference runs on the C path; --backend gpu is ignored");
        if (!vdbs_render_quality(in->scene->quality, &in->march))
            st = vdbs_error_set(err, VDBS_ERR_INPUT, "unknown quality");
        if (in->scene->sky_directions > 0)
            in->march.sky_directions = in->scene->sky_directions;
    }
    /* The density: a lit VDB's own `density` grid unless the caller names one. */
    if (st == VDBS_OK) {
        int own_grid = in->is_lit && !(d->scene_set & VDBS_SCENE_SET_GRID);
        const char *grid = own_grid ? "density" : in->scene->grid;
        vdbio_read_options read = {0};
        read.grid_name = grid[0] ? grid : NULL;
        read.grid_index = own_grid ? 0 : in->scene->grid_index;
        read.warn = d->warn;
        read.warn_user = d->warn_user;
        st = vdbs_volume_load(input, &read, &in->volume, err);
        if (st == VDBS_OK)
            st = vdbs_scene_fit_density(in->scene, &in->volume, err);
        /* The same grid gives the same scale up to rounding. */
        if (st == VDBS_OK && baked_scale > 0.0 &&
            !(fabs(in->scene->density_scale - baked_scale) <= 1e-9 * baked_scale))
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "--scene: its density scale (%g) differs from the one the lit "
                                "VDB was baked with (%g); add --relight to relight it (its "
                                "multiple scattering stays as baked)",
                                in->scene->density_scale, baked_scale);
        if (st == VDBS_OK && in->scene->light_count == 0)
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "no lights: give --sun, --point or --env (or a --scene)");
        if (st == VDBS_OK && in->mode == VDBS_RENDER_BAKED)
            st = vdbs_lit_grids_load(lit, in->volume.index_to_world, !d->relight, &in->ms, err);
        if (st == VDBS_OK && in->ms.depth_count > 0)
            st = use_stored(d, in, err);
    }
    if (lit)
        vdbio_lit_close(lit);
    if (st == VDBS_OK)
        choose_camera(d, in->scene, &in->volume, &in->camera);
    if (st != VDBS_OK)
        vdbs_render_input_free(in);
    return st;
}

void vdbs_render_input_free(vdbs_render_input *in)
{
    vdbs_lit_grids_free(&in->ms);
    vdbs_volume_free(&in->volume);
    free(in->scene);
    memset(in, 0, sizeof *in);
}

/* --max-memory: the render's estimate from the sizes it allocates, checked once the volume
 * and the lit grids are loaded, before the light grids (every light's at once) and the
 * picture. */
static vdbs_status check_memory(const vdbs_render_desc *d, const vdbs_render_input *in,
                                vdbs_render_report *report, vdbs_error *err)
{
    report->memory_limit = d->max_memory > 0    ? d->max_memory
                           : d->max_memory == 0 ? vdbs_memory_default_limit()
                                                : 0;
    report->memory_baseline = vdbs_memory_rss();
    vdbs_memory_estimate *e = &report->memory_estimate;
    memset(e, 0, sizeof *e);
    const int64_t pixels = (int64_t)in->camera.width * in->camera.height;
    const int reference = in->mode == VDBS_RENDER_REFERENCE;
    /* vdbs_image_alloc: rgb, and the standard errors for the reference */
    vdbs_memory_add(e, "picture", (reference ? 2 : 1) * 3 * (int64_t)sizeof(float) * pixels);
    int count = 0, oversample = 0;
    if (!reference) {
        vdbs_memory_add(e, "render buffers",
                        vdbs_march_session_bytes(
                            &in->volume, in->mode == VDBS_RENDER_BAKED ? &in->ms : NULL, pixels));
        if (!in->stored && !d->s1_march) {
            vdbs_lights_desc lights_desc = {0};
            lights_desc.sky_ordinates = in->march.sky_directions;
            vdbs_light_table lights;
            vdbs_status st = vdbs_lights_build(&in->volume, in->scene, &lights_desc, &lights, err);
            if (st != VDBS_OK)
                return st;
            count = lights.direct_count + lights.ordinate_count;
            oversample = d->s1_oversample > 0          ? d->s1_oversample
                         : in->march.s1_oversample > 0 ? in->march.s1_oversample
                                                       : VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
            vdbs_light_grid_desc gd = {oversample, 1, 0.0};
            vdbs_light_grids_memory lg;
            st = vdbs_light_grids_estimate(&in->volume, &lights, 0, count, &gd, &lg, err);
            vdbs_lights_free(&lights);
            if (st != VDBS_OK)
                return st;
            vdbs_memory_add(e, "light grids", lg.peak);
        }
    }
    char what[160];
    if (count > 0)
        snprintf(what, sizeof what, "%d light grid%s at --quality %s, --s1-oversample %d", count,
                 count == 1 ? "" : "s", in->scene->quality, oversample);
    else
        snprintf(what, sizeof what, "a %dx%d picture", in->camera.width, in->camera.height);
    vdbs_memory_estimate all = *e;
    vdbs_memory_add(&all, "loaded", report->memory_baseline);
    return vdbs_memory_check(&all, report->memory_limit,
                             d->max_memory > 0 ? "--max-memory" : VDBS_MEMORY_DEFAULT_SOURCE, what,
                             count > 0 ? "--quality, --s1-oversample, --size" : "--size", err);
}

vdbs_status vdbs_render(const vdbs_render_desc *d, vdbs_render_report *report, vdbs_error *err)
{
    memset(report, 0, sizeof *report);
    double t_start = vdbs_now();
    const char *input = NULL;
    vdbs_status st = input_path(d, &input, err);
    if (st == VDBS_OK && !d->output && !d->keep_image)
        st = vdbs_error_set(err, VDBS_ERR_INTERNAL, "vdbs_render: no output and no keep_image");
    if (st == VDBS_OK && d->output)
        st = vdbio_check_output(d->output, input, err);
    if (st != VDBS_OK)
        return st;
    vdbs_render_input in;
    if ((st = vdbs_render_open(d, &in, err)) != VDBS_OK)
        return st;
    report->mode = vdbs_render_mode_name(in.mode);
    report->camera = in.camera;
    double t_loaded = vdbs_now();
    if ((st = check_memory(d, &in, report, err)) != VDBS_OK) {
        vdbs_render_input_free(&in);
        return st;
    }
    report->peak_load = vdbs_memory_peak();
    report->peak_per_stage = vdbs_memory_reset_peak();
    if (vdbs_cancelled(d->cancel)) {
        vdbs_render_input_free(&in);
        return vdbs_error_cancelled(err);
    }

    vdbs_camera_frame frame;
    vdbs_image image;
    memset(&image, 0, sizeof image);
    st = vdbs_camera_frame_init(&report->camera, &frame, err);
    if (st == VDBS_OK)
        st = vdbs_image_alloc(&image, report->camera.width, report->camera.height,
                              in.mode == VDBS_RENDER_REFERENCE, err);
    double t_render = vdbs_now();
    if (st == VDBS_OK)
        st = render_image(d, in.mode, &in.volume, &in.ms, in.scene, &frame, &in.march, &image,
                          report, err);
    double t_rendered = vdbs_now();
    report->peak_render = vdbs_memory_peak();
    report->peak_per_stage &= vdbs_memory_reset_peak();
    if (st == VDBS_OK && d->output)
        st = vdbs_image_write_cancel(d->output, &image, d->exposure, d->cancel, err);
    double t_written = vdbs_now();
    report->peak_write = vdbs_memory_peak();
    /* A cancel after the rename: the new picture stays, the caller still hears of it. */
    if (st == VDBS_OK && vdbs_cancelled(d->cancel))
        st = vdbs_error_cancelled(err);

    if (st == VDBS_OK) {
        snprintf(report->grid, sizeof report->grid, "%s", in.volume.info.name);
        snprintf(report->quality, sizeof report->quality, "%s", in.scene->quality);
        report->width = report->camera.width;
        report->height = report->camera.height;
        report->sky_directions = in.march.sky_directions;
        report->step_voxels = in.march.step_voxels;
        memcpy(report->camera_up, frame.up, sizeof report->camera_up);
        report->seconds_load = t_loaded - t_start;
        report->seconds_render = t_rendered - t_render;
        report->seconds_write = t_written - t_rendered;
        report->seconds_total = vdbs_now() - t_start;
        if (d->keep_image) {
            *d->keep_image = image;
            memset(&image, 0, sizeof image);
        }
    }
    vdbs_image_free(&image);
    vdbs_render_input_free(&in);
    return st;
}
