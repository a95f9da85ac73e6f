/* vdbscatter render IN.vdb -o IMAGE.exr|IMAGE.png: a picture of a density or lit VDB. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "options.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/camera.h"
#include "vdbscatter/gpu.h"
#include "vdbscatter/image.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

static const char help[] =
    "usage: vdbscatter render IN.vdb -o IMAGE.exr|IMAGE.png [options]\n"
    "\n"
    "Renders a picture of a density VDB or of a lit VDB written by `vdbscatter bake`.\n"
    "Per pixel L = integral T sigma_s S(x, wo) dt + T * background (the env colour).\n"
    "\n"
    "modes (--mode; default: baked for a lit VDB, single otherwise):\n"
    "  single      S = S1 only: marched transmittance to every sun and point light,\n"
    "              and a fixed quadrature of sky directions (deterministic)\n"
    "  baked       S1 as in single plus Sms from the lit VDB's ms and ms_l1* grids\n"
    "  reference   Monte-Carlo path tracing of the density, all scattering orders\n"
    "              (EXR files also get the per-pixel standard errors se.R, se.G, se.B)\n"
    "\n"
    "scene (flags override --scene; light flags replace the scene's lights; for a lit VDB\n"
    "the medium and lights default to the ones it was baked with, and its `density` grid\n"
    "is rendered):\n"
    "  --scene FILE.json        scene file (volume, lights, camera, quality)\n"
    "  --grid NAME[@INDEX]      density grid (default: density, or the only float grid)\n"
    "  --density-scale S        sigma_t = density * S (per world unit; default 1)\n"
    "  --albedo A | R,G,B       single-scattering albedo (default 0.5)\n"
    "  --g G                    Henyey-Greenstein anisotropy in [-0.999, 0.999] (default 0)\n"
    "  --sun DX,DY,DZ[:R,G,B]   sun travelling along D with irradiance RGB (default 1)\n"
    "  --point X,Y,Z[:R,G,B]    point light at X,Y,Z with intensity RGB W/sr (default 1)\n"
    "  --env R,G,B              constant sky radiance (also the background)\n"
    "  --quality Q              single/baked: low | medium | high | ultra = 16 / 64 / 256 /\n"
    "                           1024 sky directions and camera-ray steps of 1 / 0.5 / 0.25 /\n"
    "                           0.125 voxel (default medium, or the scene's)\n"
    "\n"
    "camera (default: the scene's camera, else a view of the whole volume from +Z):\n"
    "  --camera PX,PY,PZ:TX,TY,TZ:FOV   position, target and vertical field of view in\n"
    "                           degrees; up is +Y (-Z for a view straight up or down)\n"
    "  --size WxH               image size (default: the scene camera's, else 640x480)\n"
    "\n"
    "reference mode:\n"
    "  --spp N                  samples per pixel (default 64; per round with --time)\n"
    "  --time SECONDS           render rounds of --spp samples (default 4) until the time\n"
    "                           is spent\n"
    "  --max-bounces K          scattering events per path (default 1000)\n"
    "  --seed S                 random seed (default 1); the same seed gives the same image\n"
    "\n"
    "other options:\n"
    "  -o, --output FILE        .exr (linear float) or .png (8-bit sRGB)\n"
    "  --mode single|baked|reference\n"
    "  --backend auto|cpu|gpu   single/baked: auto = a hardware GPU if EGL finds one, else\n"
    "                           the C path; reference always runs on the C path\n"
    "  --exposure EV            PNG only: scale by 2^EV before the sRGB encoding\n"
    "  --json                   print a summary as JSON on stdout\n"
    "  -q                       no progress, summary or warnings\n";

static const cli_option options[] = {
    {"-o", CLI_VALUE},         {"--output", CLI_VALUE},
    {"--camera", CLI_VALUE},   {"--size", CLI_VALUE},
    {"--mode", CLI_VALUE},     {"--backend", CLI_VALUE},
    {"--exposure", CLI_VALUE}, {"--spp", CLI_VALUE},
    {"--time", CLI_VALUE},     {"--max-bounces", CLI_VALUE},
    {"--seed", CLI_VALUE},     {"--json", CLI_FLAG},
    {"-q", CLI_FLAG},          {"--scene", CLI_VALUE},
    {"--grid", CLI_VALUE},     {"--density-scale", CLI_VALUE},
    {"--albedo", CLI_VALUE},   {"--g", CLI_VALUE},
    {"--sun", CLI_VALUE},      {"--point", CLI_VALUE},
    {"--env", CLI_VALUE},      {"--quality", CLI_VALUE},
    {NULL, CLI_FLAG},
};

typedef enum render_mode { MODE_SINGLE, MODE_BAKED, MODE_REFERENCE } render_mode;
static const char *const mode_names[] = {"single", "baked", "reference"};

typedef struct render_args {
    const char *output;
    render_mode mode;
    int mode_given;
    vdbs_backend backend;
    int backend_given;
    double exposure;
    int width, height, size_given;
    vdbs_camera camera; /* present when --camera was given */
    long spp, max_bounces;
    int spp_given;
    double time_limit;
    unsigned long long seed;
} render_args;

static vdbs_status parse_size(const char *text, int *width, int *height, vdbs_error *err)
{
    char *end = NULL;
    errno = 0;
    long w = strtol(text, &end, 10);
    if (end != text && (*end == 'x' || *end == 'X') && errno == 0) {
        const char *rest = end + 1;
        long h = strtol(rest, &end, 10);
        if (end != rest && *end == '\0' && errno == 0 && w >= 1 && w <= 16384 && h >= 1 &&
            h <= 16384 && text[0] != '-' && text[0] != '+' && rest[0] != '-' && rest[0] != '+') {
            *width = (int)w;
            *height = (int)h;
            return VDBS_OK;
        }
    }
    return vdbs_error_set(err, VDBS_ERR_INPUT,
                          "--size: expected WxH with integers in [1, 16384], got '%s'", text);
}

/* "PX,PY,PZ:TX,TY,TZ:FOV"; up is +Y unless the view is vertical. */
static vdbs_status parse_camera(const char *text, vdbs_camera *camera, vdbs_error *err)
{
    char buf[512];
    if (strlen(text) >= sizeof buf)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--camera: value too long");
    strcpy(buf, text);
    char *parts[4] = {NULL, NULL, NULL, NULL};
    int n = 0;
    char *p = buf;
    while (n < 4) {
        parts[n++] = p;
        char *colon = strchr(p, ':');
        if (!colon)
            break;
        *colon = '\0';
        p = colon + 1;
    }
    memset(camera, 0, sizeof *camera);
    if (n != 3 || cli_triple("--camera", parts[0], 0, camera->position, NULL) != VDBS_OK ||
        cli_triple("--camera", parts[1], 0, camera->target, NULL) != VDBS_OK ||
        cli_number("--camera", parts[2], &camera->fov_deg, NULL) != VDBS_OK)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--camera: expected PX,PY,PZ:TX,TY,TZ:FOV_DEG, got '%s'", text);
    if (!(camera->fov_deg > 0.0 && camera->fov_deg < 180.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--camera: the field of view must be in (0, 180) degrees, got %g",
                              camera->fov_deg);
    double f[3], len2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        f[a] = camera->target[a] - camera->position[a];
        len2 += f[a] * f[a];
    }
    if (!(len2 > 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--camera: the position equals the target");
    camera->present = 1;
    camera->up[1] = 1.0;
    /* A vertical view has no horizon to keep level: put -Z at the top of the image. */
    if (f[0] * f[0] + f[2] * f[2] <= 1e-12 * len2) {
        camera->up[1] = 0.0;
        camera->up[2] = -1.0;
    }
    return VDBS_OK;
}

static int has_suffix(const char *path, const char *suffix)
{
    size_t n = strlen(path), m = strlen(suffix);
    return n > m && strcasecmp(path + n - m, suffix) == 0;
}

static vdbs_status parse_args(const cli_args *args, render_args *r, vdbs_error *err)
{
    vdbs_status st;
    memset(r, 0, sizeof *r);
    r->output = cli_output(args);
    if (!r->output)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "missing -o IMAGE.exr or IMAGE.png");
    if (!has_suffix(r->output, ".exr") && !has_suffix(r->output, ".png"))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "-o: unsupported image type '%s' (use .exr or .png)", r->output);
    const char *v;
    if ((v = cli_value(args, "--mode"))) {
        int found = 0;
        for (int m = 0; m < 3; ++m)
            if (strcmp(v, mode_names[m]) == 0) {
                r->mode = (render_mode)m;
                found = 1;
            }
        if (!found)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "--mode: expected single, baked or reference, got '%s'", v);
        r->mode_given = 1;
    }
    if ((v = cli_value(args, "--backend"))) {
        if ((st = vdbs_backend_parse(v, &r->backend, err)) != VDBS_OK)
            return st;
        r->backend_given = 1;
    }
    if ((v = cli_value(args, "--exposure")) &&
        (st = cli_number("--exposure", v, &r->exposure, err)) != VDBS_OK)
        return st;
    if ((v = cli_value(args, "--size"))) {
        if ((st = parse_size(v, &r->width, &r->height, err)) != VDBS_OK)
            return st;
        r->size_given = 1;
    }
    if ((v = cli_value(args, "--camera")) && (st = parse_camera(v, &r->camera, err)) != VDBS_OK)
        return st;
    r->spp = 64;
    if ((v = cli_value(args, "--spp"))) {
        if ((st = cli_integer("--spp", v, 1, 1000000000L, &r->spp, err)) != VDBS_OK)
            return st;
        r->spp_given = 1;
    }
    if ((v = cli_value(args, "--time"))) {
        if ((st = cli_number("--time", v, &r->time_limit, err)) != VDBS_OK)
            return st;
        if (!(r->time_limit > 0.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--time: expected seconds > 0, got '%s'", v);
        if (!r->spp_given)
            r->spp = 4;
    }
    r->max_bounces = 1000;
    if ((v = cli_value(args, "--max-bounces")) &&
        (st = cli_integer("--max-bounces", v, 1, 1000000000L, &r->max_bounces, err)) != VDBS_OK)
        return st;
    r->seed = 1;
    if ((v = cli_value(args, "--seed"))) {
        char *end = NULL;
        errno = 0;
        unsigned long long s = strtoull(v, &end, 10);
        if (end == v || *end != '\0' || errno == ERANGE || v[0] == '-' || v[0] == '+')
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "--seed: expected a non-negative integer, got '%s'", v);
        r->seed = s;
    }
    return VDBS_OK;
}

static int light_flag_given(const cli_args *args)
{
    return cli_value(args, "--sun") || cli_value(args, "--point") || cli_value(args, "--env");
}

/* The scene of a lit VDB: its baked scene with the medium and light flags on top. */
static void apply_flags(const cli_args *args, const vdbs_scene *flags, vdbs_scene *scene)
{
    if (cli_value(args, "--density-scale"))
        scene->density_scale = flags->density_scale;
    if (cli_value(args, "--albedo"))
        memcpy(scene->albedo, flags->albedo, sizeof scene->albedo);
    if (cli_value(args, "--g"))
        scene->g = flags->g;
    if (cli_value(args, "--quality"))
        strcpy(scene->quality, flags->quality);
    if (light_flag_given(args)) {
        memcpy(scene->lights, flags->lights, sizeof scene->lights);
        scene->light_count = flags->light_count;
    }
    if (cli_value(args, "--grid")) {
        strcpy(scene->grid, flags->grid);
        scene->grid_index = flags->grid_index;
    }
}

static void warn_line(int quiet, const char *fmt, const char *arg)
{
    char line[512];
    snprintf(line, sizeof line, fmt, arg);
    cli_warn(&quiet, line);
}

static cJSON *triple(const double v[3])
{
    return cJSON_CreateDoubleArray(v, 3);
}

int cmd_render(int argc, char **argv)
{
    cli_args args;
    vdbs_error err;
    vdbs_status st;
    double t_start = vdbs_now();
    if (cli_parse(argc, argv, options, &args, &err) != VDBS_OK)
        return cli_fail("render", 2, err.message);
    if (args.help) {
        fputs(help, stdout);
        return CLI_EXIT_OK;
    }
    if (args.positional_count > 1)
        return cli_fail("render", 2, "expected one input VDB");
    render_args r;
    if ((st = parse_args(&args, &r, &err)) != VDBS_OK)
        return cli_fail("render", st, err.message);
    int quiet = cli_flag(&args, "-q");
    static vdbs_scene flags, scene;
    if ((st = cli_build_scene(&args, &flags, 1, &err)) != VDBS_OK)
        return cli_fail("render", st, err.message);
    const char *input = args.positional_count ? args.positional[0] : flags.volume_file;
    if (!input[0])
        return cli_fail("render", 2, "no input VDB (give IN.vdb or volume.file in --scene)");
    if ((st = vdbio_check_output(r.output, input, &err)) != VDBS_OK)
        return cli_fail("render", st, err.message);

    /* A lit VDB (written by bake) brings its scene and, for baked mode, the ms grids. */
    vdbio_lit *lit = NULL;
    if ((st = vdbio_lit_open(input, &lit, &err)) != VDBS_OK)
        return cli_fail("render", st, err.message);
    const char *meta = vdbio_lit_meta(lit, "vdbscatter_scene");
    int is_lit = meta && vdbio_lit_has_grid(lit, "radiance") && vdbio_lit_has_grid(lit, "density");
    static vdbs_scene baked_scene;
    if (is_lit && (st = vdbs_scene_parse(meta, NULL, &baked_scene, &err)) != VDBS_OK) {
        vdbio_lit_close(lit);
        vdbs_error line;
        vdbs_error_set(&line, VDBS_ERR_INPUT, "%s: vdbscatter_scene metadata: %s", input,
                       err.message);
        return cli_fail("render", 2, line.message);
    }
    if (!r.mode_given)
        r.mode = is_lit ? MODE_BAKED : MODE_SINGLE;
    if (r.mode == MODE_BAKED && !is_lit) {
        vdbio_lit_close(lit);
        vdbs_error_set(&err, VDBS_ERR_INPUT,
                       "--mode baked needs a lit VDB written by vdbscatter bake ('%s' has no "
                       "radiance grid and vdbscatter_scene metadata)",
                       input);
        return cli_fail("render", 2, err.message);
    }

    /* Scene: --scene and the flags; for a lit VDB without --scene, its baked scene with the
     * flags on top (a --scene file replaces the baked scene). */
    if (is_lit && !cli_value(&args, "--scene")) {
        scene = baked_scene;
        apply_flags(&args, &flags, &scene);
    } else {
        scene = flags;
        if (is_lit && scene.light_count == 0) {
            memcpy(scene.lights, baked_scene.lights, sizeof scene.lights);
            scene.light_count = baked_scene.light_count;
        }
    }
    if (scene.light_count == 0) {
        vdbio_lit_close(lit);
        return cli_fail("render", 2, "no lights: give --sun, --point or --env (or a --scene)");
    }
    if ((st = vdbs_scene_validate(&scene, &err)) != VDBS_OK) {
        vdbio_lit_close(lit);
        return cli_fail("render", st, err.message);
    }
    for (int i = 0; i < scene.light_count; ++i)
        if (scene.lights[i].type == VDBS_LIGHT_SUN && scene.lights[i].angular_diameter_deg > 0) {
            warn_line(quiet, "%s", "sun angular_diameter_deg is treated as 0 (a delta light)");
            break;
        }
    if (r.mode == MODE_REFERENCE && r.backend == VDBS_BACKEND_GPU)
        warn_line(quiet, "%s", "--mode reference runs on the C path; --backend gpu is ignored");
    if (r.mode != MODE_REFERENCE) {
        static const char *const ref_only[] = {"--spp", "--time", "--max-bounces", "--seed"};
        for (int i = 0; i < 4; ++i)
            if (cli_value(&args, ref_only[i]))
                warn_line(quiet, "%s applies to --mode reference only; ignored", ref_only[i]);
    }
    vdbs_march_options march = {0};
    if (!vdbs_render_quality(scene.quality, &march)) {
        vdbio_lit_close(lit);
        return cli_fail("render", 2, "unknown quality");
    }

    /* The density: a lit VDB's own `density` grid unless --grid says otherwise. */
    vdbio_read_options read = {0};
    const char *grid = cli_value(&args, "--grid") || !is_lit ? scene.grid : "density";
    read.grid_name = grid[0] ? grid : NULL;
    read.grid_index = is_lit && !cli_value(&args, "--grid") ? 0 : scene.grid_index;
    read.warn = cli_warn;
    read.warn_user = &quiet;
    vdbs_volume volume;
    vdbs_ms_grids ms;
    memset(&ms, 0, sizeof ms);
    st = vdbs_volume_load(input, &read, &volume, &err);
    if (st == VDBS_OK && r.mode == MODE_BAKED)
        st = vdbs_ms_grids_load(lit, volume.index_to_world, &ms, &err);
    vdbio_lit_close(lit);
    if (st != VDBS_OK) {
        vdbs_volume_free(&volume); /* zeroed by a failed load */
        return cli_fail("render", st, err.message);
    }
    double t_loaded = vdbs_now();

    /* Camera: --camera, else the scene's, else a view of the whole volume. */
    vdbs_camera camera;
    int width = r.size_given ? r.width : 640, height = r.size_given ? r.height : 480;
    if (r.camera.present) {
        camera = r.camera;
    } else if (scene.camera.present) {
        camera = scene.camera;
        if (!r.size_given) {
            width = camera.width;
            height = camera.height;
        }
    } else {
        vdbs_camera_frame_volume(&volume, width, height, &camera);
    }
    camera.width = width;
    camera.height = height;
    vdbs_camera_frame frame;
    vdbs_image image;
    memset(&image, 0, sizeof image);
    st = vdbs_camera_frame_init(&camera, &frame, &err);
    if (st == VDBS_OK)
        st = vdbs_image_alloc(&image, width, height, r.mode == MODE_REFERENCE, &err);

    vdbs_progress progress;
    int show_progress = !quiet && isatty(STDERR_FILENO);
    char backend[16] = "cpu", renderer[256];
    snprintf(renderer, sizeof renderer, "C (OpenMP, %d threads)", omp_get_max_threads());
    int spp_done = 1;
    double t_render = vdbs_now();
    if (st == VDBS_OK && r.mode == MODE_REFERENCE) {
        vdbs_reference_options ro = {0};
        ro.spp = (int)r.spp;
        ro.time_limit = r.time_limit;
        ro.max_bounces = (int)r.max_bounces;
        ro.seed = r.seed;
        ro.progress = &progress;
        vdbs_progress_begin(&progress, show_progress, "render (reference)",
                            (uint64_t)width * height * (uint64_t)r.spp);
        st = vdbs_reference_render(&volume, &scene, &frame, &ro, &image, &spp_done, &err);
    } else if (st == VDBS_OK) {
        vdbs_backend b = r.backend;
        if (b == VDBS_BACKEND_AUTO)
            b = vdbs_gpu_hardware_available() ? VDBS_BACKEND_GPU : VDBS_BACKEND_CPU;
        march.progress = &progress;
        vdbs_progress_begin(&progress, show_progress, "render", (uint64_t)width * height);
        if (b == VDBS_BACKEND_GPU) {
            vdbs_gpu *gpu = NULL;
            st = vdbs_gpu_create(&gpu, &err);
            if (st == VDBS_OK) {
                snprintf(backend, sizeof backend, "gpu");
                snprintf(renderer, sizeof renderer, "%s", vdbs_gpu_get_info(gpu)->renderer);
                st = vdbs_render_march_gpu(gpu, &volume, r.mode == MODE_BAKED ? &ms : NULL, &scene,
                                           &frame, &march, &image, &err);
                vdbs_gpu_destroy(gpu);
            }
        } else {
            st = vdbs_render_march_cpu(&volume, r.mode == MODE_BAKED ? &ms : NULL, &scene, &frame,
                                       &march, &image, &err);
        }
    }
    if (st == VDBS_OK)
        vdbs_progress_end(&progress);
    double t_rendered = vdbs_now();
    if (st == VDBS_OK)
        st = vdbs_image_write(r.output, &image, r.exposure, &err);
    double t_written = vdbs_now();
    vdbs_ms_grids_free(&ms);
    vdbs_image_free(&image);
    if (st != VDBS_OK) {
        vdbs_volume_free(&volume);
        return cli_fail("render", st, err.message);
    }

    if (cli_flag(&args, "--json")) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "input", input);
        cJSON_AddStringToObject(j, "output", r.output);
        cJSON_AddStringToObject(j, "grid", volume.info.name);
        cJSON_AddStringToObject(j, "mode", mode_names[r.mode]);
        cJSON_AddStringToObject(j, "backend", backend);
        cJSON_AddStringToObject(j, "renderer", renderer);
        cJSON_AddNumberToObject(j, "width", width);
        cJSON_AddNumberToObject(j, "height", height);
        if (r.mode == MODE_REFERENCE) {
            cJSON_AddNumberToObject(j, "spp", spp_done);
            cJSON_AddNumberToObject(j, "max_bounces", (double)r.max_bounces);
            cJSON_AddNumberToObject(j, "seed", (double)r.seed);
        } else {
            cJSON_AddNumberToObject(j, "spp", 1);
            cJSON_AddStringToObject(j, "quality", scene.quality);
            cJSON_AddNumberToObject(j, "sky_directions", march.sky_directions);
            cJSON_AddNumberToObject(j, "step_voxels", march.step_voxels);
        }
        cJSON_AddNumberToObject(j, "exposure", r.exposure);
        cJSON *c = cJSON_AddObjectToObject(j, "camera");
        cJSON_AddItemToObject(c, "position", triple(camera.position));
        cJSON_AddItemToObject(c, "target", triple(camera.target));
        cJSON_AddItemToObject(c, "up", triple(frame.up));
        cJSON_AddNumberToObject(c, "fov_deg", camera.fov_deg);
        cJSON *t = cJSON_AddObjectToObject(j, "seconds");
        cJSON_AddNumberToObject(t, "load", t_loaded - t_start);
        cJSON_AddNumberToObject(t, "render", t_rendered - t_render);
        cJSON_AddNumberToObject(t, "write", t_written - t_rendered);
        cJSON_AddNumberToObject(t, "total", vdbs_now() - t_start);
        char *text = cJSON_Print(j);
        puts(text);
        free(text);
        cJSON_Delete(j);
    } else if (!quiet) {
        char detail[64];
        if (r.mode == MODE_REFERENCE)
            snprintf(detail, sizeof detail, "%d spp", spp_done);
        else
            snprintf(detail, sizeof detail, "quality %s", scene.quality);
        fprintf(stderr, "rendered %dx%d of '%s' (%s, %s) on %s in %.2fs -> %s\n", width, height,
                volume.info.name, mode_names[r.mode], detail, backend, t_rendered - t_render,
                r.output);
    }
    vdbs_volume_free(&volume);
    return CLI_EXIT_OK;
}
