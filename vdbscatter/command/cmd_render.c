/* vdbscatter render IN.vdb -o IMAGE.exr|IMAGE.png: a picture of a density or lit VDB. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "options.h"
#include "sequence.h"
#include "vdbscatter/message.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene.h"

static const char help[] =
    "usage: vdbscatter render IN.vdb -o IMAGE.exr|IMAGE.png [options]\n"
    "       vdbscatter render IN.####.vdb -o IMAGE.####.exr [--frames 1-240] [options]\n"
    "\n"
    "Renders a picture of a density VDB or of a lit VDB written by `vdbscatter bake`.\n"
    "Per pixel L = integral T sigma_s S(x, wo) dt + T * background (the env colour).\n"
    "\n"
    "modes (--mode; default: baked for a lit VDB, single otherwise):\n"
    "  single      S = S1 only: transmittance to every sun and point light and a fixed\n"
    "              quadrature of sky directions, from light grids (or marched: --s1)\n"
    "  baked       the lit VDB as baked: S1 from its stored optical depths to the lights\n"
    "              (light grids swept for older files) plus Sms from its ms and ms_l1*\n"
    "              grids; flags that change its lights or medium need --relight\n"
    "  reference   Monte-Carlo path tracing of the density, all scattering orders\n"
    "              (EXR files also get the per-pixel standard errors se.R, se.G, se.B)\n"
    "\n"
    "scene (flags override --scene; light flags replace the scene's lights; for a lit VDB\n"
    "the medium and lights default to the ones it was baked with, and its `density` grid\n"
    "is rendered):\n"
    "  --scene FILE.json        scene file (volume, lights, camera, quality)\n"
    "  --grid NAME[@INDEX]      density grid (default: density, or the only float grid)\n"
    "  --density-scale S        sigma_t = density * S (per world unit; default 1), or\n"
    "                           auto:TAU for a mean optical depth TAU through the volume\n"
    "                           (clouds look like clouds at about 5-20; see info --target-depth)\n"
    "  --albedo A | R,G,B       single-scattering albedo (default 0.5)\n"
    "  --g G                    Henyey-Greenstein anisotropy in [-0.999, 0.999] (default 0)\n"
    "  --sun DX,DY,DZ[:R,G,B]   sun travelling along D with irradiance RGB (default 1)\n"
    "  --point X,Y,Z[:R,G,B]    point light at X,Y,Z with intensity RGB W/sr (default 1)\n"
    "  --env R,G,B | FILE[:S]   constant sky radiance, or a lat-long OpenEXR / Radiance HDR\n"
    "                           map times S (also the background)\n"
    "  --sky-directions K       sky quadrature directions (default: the quality's)\n"
    "  --quality Q              single/baked: low | medium | high | ultra = 16 / 64 / 256 /\n"
    "                           1024 sky directions and camera-ray steps of 1 / 0.5 / 0.25 /\n"
    "                           0.125 voxel (default low, or the scene's)\n"
    "\n"
    "camera (default: the scene's camera, else a view of the whole volume from +Z):\n"
    "  --camera PX,PY,PZ:TX,TY,TZ:FOV   position, target and vertical field of view in\n"
    "                           degrees; up is +Y (-Z for a view straight up or down)\n"
    "  --size WxH               image size (default: the scene camera's, else 640x480)\n"
    "\n"
    "reference mode:\n"
    "  --spp N                  samples per pixel (default 64; per round with --time,\n"
    "                           the first round with --tolerance)\n"
    "  --time SECONDS           render rounds of --spp samples (default 4) until the time\n"
    "                           is spent\n"
    "  --tolerance E            render rounds until the image's relative noise (the\n"
    "                           image relative RMSE it carries) is at most E, each sized\n"
    "                           by the noise so far (default --spp 16); with --time, stop\n"
    "                           at whichever comes first; --json reports the noise\n"
    "  --max-bounces K          scattering events per path (default 1000)\n"
    "  --seed S                 random seed (default 1); the same seed gives the same image\n"
    "  --env-nee on|off         next-event estimation toward an env map, combined with HG\n"
    "                           sampling by MIS (default on; off: HG sampling alone)\n"
    "\n"
    "other options:\n"
    "  -o, --output FILE        .exr (linear float) or .png (8-bit sRGB)\n"
    "  --mode single|baked|reference\n"
    "  --relight                baked: S1 from light grids swept for the lights and medium\n"
    "                           as given (the flags above on top of the baked ones); Sms\n"
    "                           stays as baked\n"
    "  --backend auto|cpu|gpu   single/baked: auto = a hardware GPU if EGL finds one, else\n"
    "                           the C path; reference always runs on the C "
    "path\n" VDBS_OPTIONS_S1_HELP
    "  --exposure EV            PNG only: scale by 2^EV before the sRGB "
    "encoding\n" VDBS_OPTIONS_MAX_MEMORY_HELP
    "  --json                   print a summary as JSON on stdout (memory: the estimate\n"
    "                           and each stage's peak)\n"
    "  -q                       no progress, summary or warnings\n" VDBS_OPTIONS_RUN_HELP "\n"
    "frame sequences (docs/sequences.md): a frame number in IN and -o (####, $F4,\n"
    "%04d) renders every frame:\n"
    "  --frames LIST            1-240, 1-240x2, 1,5,9 (default: the input frames on disk)\n"
    "  --skip-missing           render the frames whose input is there\n"
    "  --fps R                  the frame rate, into the summary\n"
    "  --summary FILE.json      the sequence summary, rewritten after every frame\n";

static const vdbs_arg_option options[] = {
    VDBS_OPTIONS_COMMON,
    {"--camera", VDBS_ARG_VALUE},
    {"--size", VDBS_ARG_VALUE},
    {"--mode", VDBS_ARG_VALUE},
    {"--exposure", VDBS_ARG_VALUE},
    {"--spp", VDBS_ARG_VALUE},
    {"--time", VDBS_ARG_VALUE},
    {"--tolerance", VDBS_ARG_VALUE},
    {"--max-bounces", VDBS_ARG_VALUE},
    {"--seed", VDBS_ARG_VALUE},
    {"--env-nee", VDBS_ARG_VALUE},
    {"--relight", VDBS_ARG_FLAG},
    {"--max-memory", VDBS_ARG_VALUE},
    VDBS_SEQUENCE_OPTIONS,
    {NULL, VDBS_ARG_FLAG},
};

typedef struct render_args {
    const char *output;
    vdbs_render_mode mode; /* VDBS_RENDER_DEFAULT unless --mode */
    vdbs_backend backend;
    double exposure;
    int width, height, size_given;
    vdbs_camera camera; /* present when --camera was given */
    long spp, max_bounces;
    int spp_given;
    double time_limit, tolerance;
    unsigned long long seed;
    int s1_march, s1_oversample;
    int no_env_nee;
    int relight;
} render_args;

static int has_suffix(const char *path, const char *suffix)
{
    size_t n = strlen(path), m = strlen(suffix);
    return n > m && strcasecmp(path + n - m, suffix) == 0;
}

static vdbs_status parse_args(const vdbs_options_args *args, render_args *r, vdbs_error *err)
{
    vdbs_status st;
    memset(r, 0, sizeof *r);
    r->output = vdbs_options_output(args);
    if (!r->output && !vdbs_command_keeps_image()) /* a binding may take the picture instead */
        return vdbs_error_set(err, VDBS_ERR_INPUT, "missing -o IMAGE.exr or IMAGE.png");
    if (r->output && !has_suffix(r->output, ".exr") && !has_suffix(r->output, ".png"))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "-o: unsupported image type '%s' (use .exr or .png)", r->output);
    const char *v;
    if ((v = vdbs_options_value(args, "--mode"))) {
        for (int m = VDBS_RENDER_SINGLE; m <= VDBS_RENDER_REFERENCE; ++m)
            if (strcmp(v, vdbs_render_mode_name((vdbs_render_mode)m)) == 0)
                r->mode = (vdbs_render_mode)m;
        if (r->mode == VDBS_RENDER_DEFAULT)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "--mode: expected single, baked or reference, got '%s'", v);
    }
    if ((v = vdbs_options_value(args, "--backend"))) {
        if ((st = vdbs_backend_parse(v, &r->backend, err)) != VDBS_OK)
            return st;
    }
    if ((st = vdbs_options_s1(args, &r->s1_march, &r->s1_oversample, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--exposure")) &&
        (st = vdbs_options_number("--exposure", v, &r->exposure, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--size"))) {
        if ((st = vdbs_options_size(v, &r->width, &r->height, err)) != VDBS_OK)
            return st;
        r->size_given = 1;
    }
    if ((v = vdbs_options_value(args, "--camera")) &&
        (st = vdbs_options_camera(v, &r->camera, err)) != VDBS_OK)
        return st;
    r->spp = 64;
    if ((v = vdbs_options_value(args, "--spp"))) {
        if ((st = vdbs_options_integer("--spp", v, 1, 1000000000L, &r->spp, err)) != VDBS_OK)
            return st;
        r->spp_given = 1;
    }
    if ((v = vdbs_options_value(args, "--time"))) {
        if ((st = vdbs_options_number("--time", v, &r->time_limit, err)) != VDBS_OK)
            return st;
        if (!(r->time_limit > 0.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--time: expected seconds > 0, got '%s'", v);
        if (!r->spp_given)
            r->spp = 4;
    }
    if ((v = vdbs_options_value(args, "--tolerance"))) {
        if ((st = vdbs_options_number("--tolerance", v, &r->tolerance, err)) != VDBS_OK)
            return st;
        if (!(r->tolerance > 0.0 && r->tolerance < 1.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "--tolerance: expected a relative noise in (0, 1), got '%s'", v);
        if (!r->spp_given)
            r->spp = 16;
    }
    r->relight = vdbs_options_flag(args, "--relight");
    r->max_bounces = 1000;
    if ((v = vdbs_options_value(args, "--max-bounces")) &&
        (st = vdbs_options_integer("--max-bounces", v, 1, 1000000000L, &r->max_bounces, err)) !=
            VDBS_OK)
        return st;
    r->seed = 1;
    if ((v = vdbs_options_value(args, "--seed"))) {
        char *end = NULL;
        errno = 0;
        unsigned long long s = strtoull(v, &end, 10);
        if (end == v || *end != '\0' || errno == ERANGE || v[0] == '-' || v[0] == '+')
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "--seed: expected a non-negative integer, got '%s'", v);
        r->seed = s;
    }
    if ((v = vdbs_options_value(args, "--env-nee"))) {
        if (strcmp(v, "on") != 0 && strcmp(v, "off") != 0)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--env-nee: expected on or off, got '%s'",
                                  v);
        r->no_env_nee = strcmp(v, "off") == 0;
    }
    return VDBS_OK;
}

static void warn_line(int quiet, const char *fmt, const char *arg)
{
    char line[512];
    snprintf(line, sizeof line, fmt, arg);
    vdbs_command_warn(&quiet, line);
}

static cJSON *render_json(const char *input, const char *output, const render_args *r,
                          const vdbs_render_report *rep)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "input", input);
    if (output)
        cJSON_AddStringToObject(j, "output", output);
    else
        cJSON_AddNullToObject(j, "output");
    cJSON_AddStringToObject(j, "grid", rep->grid);
    cJSON_AddStringToObject(j, "mode", rep->mode);
    cJSON_AddStringToObject(j, "backend", rep->backend);
    cJSON_AddStringToObject(j, "renderer", rep->renderer);
    cJSON_AddNumberToObject(j, "width", rep->width);
    cJSON_AddNumberToObject(j, "height", rep->height);
    if (r->mode == VDBS_RENDER_REFERENCE) {
        cJSON_AddNumberToObject(j, "spp", rep->spp);
        cJSON_AddNumberToObject(j, "noise", rep->noise);
        if (r->tolerance > 0.0)
            cJSON_AddNumberToObject(j, "tolerance", r->tolerance);
        cJSON_AddNumberToObject(j, "max_bounces", (double)r->max_bounces);
        cJSON_AddNumberToObject(j, "seed", (double)r->seed);
    } else {
        cJSON_AddNumberToObject(j, "spp", 1);
        cJSON_AddStringToObject(j, "quality", rep->quality);
        cJSON_AddNumberToObject(j, "sky_directions", rep->sky_directions);
        cJSON_AddNumberToObject(j, "step_voxels", rep->step_voxels);
    }
    cJSON_AddNumberToObject(j, "exposure", r->exposure);
    cJSON *c = cJSON_AddObjectToObject(j, "camera");
    cJSON_AddItemToObject(c, "position", vdbs_options_json_triple(rep->camera.position));
    cJSON_AddItemToObject(c, "target", vdbs_options_json_triple(rep->camera.target));
    cJSON_AddItemToObject(c, "up", vdbs_options_json_triple(rep->camera_up));
    cJSON_AddNumberToObject(c, "fov_deg", rep->camera.fov_deg);
    cJSON *t = cJSON_AddObjectToObject(j, "seconds");
    cJSON_AddNumberToObject(t, "load", rep->seconds_load);
    cJSON_AddNumberToObject(t, "render", rep->seconds_render);
    cJSON_AddNumberToObject(t, "write", rep->seconds_write);
    cJSON_AddNumberToObject(t, "total", rep->seconds_total);
    if (rep->s1[0]) {
        cJSON_AddStringToObject(j, "s1", rep->s1);
        cJSON_AddBoolToObject(j, "relight", r->relight);
        if (rep->s1_oversample > 0) {
            cJSON_AddNumberToObject(j, "s1_oversample", rep->s1_oversample);
            cJSON_AddNumberToObject(t, "s1_sweep", rep->march_stats.grids.seconds_sweep);
            vdbs_options_json_light_grids(j, &rep->march_stats.grids);
        }
        cJSON_AddNumberToObject(t, "march", rep->march_stats.seconds_march);
    }
    const char *const stages[] = {"load", "render", "write"};
    const int64_t peaks[] = {rep->peak_load, rep->peak_render, rep->peak_write};
    vdbs_options_json_memory(j, rep->memory_limit, rep->memory_baseline, &rep->memory_estimate,
                             stages, peaks, 3, rep->peak_per_stage);
    return j;
}

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .run = run,
    .name = "render",
    .options = options,
    .help = help,
    .max_positional = 1,
    .positional_error = "expected one input VDB",
};

/* What every frame of a render shares. */
typedef struct render_request {
    const vdbs_options_args *args;
    render_args r;
    vdbs_render_desc desc; /* all but the input and output */
    int quiet;
} render_request;

/* Renders input into output (NULL: kept for the caller); the report into *report_out (a
 * sequence's frame), or printed. Returns the exit status. */
static int render_one(render_request *q, const char *input, const char *output, cJSON **report_out)
{
    vdbs_error err;
    const render_args *r = &q->r;
    vdbs_render_desc desc = q->desc;
    desc.input = input;
    desc.output = output;
    desc.warn_user = &q->quiet;
    vdbs_image kept = {0};
    if (vdbs_command_keeps_image() && !report_out)
        desc.keep_image = &kept;
    vdbs_render_report rep;
    vdbs_status st = vdbs_render(&desc, &rep, &err);
    if (st != VDBS_OK)
        return st == VDBS_ERR_CANCELLED ? vdbs_command_interrupted("render", VDBS_EXIT_FAILURE)
                                        : vdbs_command_fail("render", st, err.message);
    if (desc.keep_image)
        vdbs_command_give_image(kept.width, kept.height, kept.rgb, kept.se);
    if (r->relight && strcmp(rep.mode, "baked") != 0)
        warn_line(q->quiet, "%s applies to a lit VDB only; ignored", "--relight");
    if (report_out) {
        *report_out = render_json(input, output, r, &rep);
        return VDBS_EXIT_OK;
    }
    if (vdbs_options_flag(q->args, "--json")) {
        cJSON *j = render_json(input, output, r, &rep);
        char *text = cJSON_Print(j);
        vdbs_command_out("%s\n", text);
        free(text);
        cJSON_Delete(j);
    } else if (!q->quiet) {
        char detail[96];
        if (r->mode == VDBS_RENDER_REFERENCE)
            snprintf(detail, sizeof detail, "%d spp, relative noise %.3g", rep.spp, rep.noise);
        else
            snprintf(detail, sizeof detail, "quality %s, S1 %s%s", rep.quality,
                     strcmp(rep.s1, "stored") == 0 ? "from the stored depths" : rep.s1,
                     r->relight ? ", relit" : "");
        vdbs_message_emitf(VDBS_MESSAGE_NOTE,
                           "rendered %dx%d of '%s' (%s, %s) on %s in %.2fs -> %s\n", rep.width,
                           rep.height, rep.grid, rep.mode, detail, rep.backend, rep.seconds_render,
                           output ? output : "(kept)");
    }
    return vdbs_command_interrupted("render", VDBS_EXIT_OK); /* a signal after the rename */
}

static int frame_run(void *user, const vdbs_sequence_frame *frame, cJSON **report)
{
    render_request *q = user;
    int status = render_one(q, frame->input, frame->output, report);
    if (status == VDBS_EXIT_OK && *report)
        cJSON_AddNumberToObject(*report, "frame", (double)frame->frame);
    return status;
}

/* A sequence: every frame rendered (pictures are cheap next to bakes: none is skipped). */
static int run_sequence(render_request *q, const char *input)
{
    if (!q->r.output)
        return vdbs_command_fail("render", 2, "a sequence needs -o IMAGE.####.exr");
    vdbs_sequence_step step = {0};
    step.command = "render";
    step.worked = "rendered";
    step.run = frame_run;
    step.user = q;
    step.quiet = q->quiet;
    return vdbs_sequence_run(q->args, input, q->r.output, &step);
}

static int run(const vdbs_options_args *args)
{
    vdbs_error err;
    vdbs_status st;
    render_request *q = calloc(1, sizeof *q);
    vdbs_scene *scene = malloc(sizeof *scene);
    if (!q || !scene) {
        free(q);
        free(scene);
        return vdbs_command_fail("render", 1, "out of memory");
    }
    q->args = args;
    render_args *r = &q->r;
    int status = VDBS_EXIT_OK;
    const int quiet = q->quiet = vdbs_options_flag(args, "-q");
    if ((st = parse_args(args, r, &err)) != VDBS_OK ||
        (st = vdbs_options_build_scene(args, scene, 1, &err)) != VDBS_OK ||
        (st = vdbs_options_scene_occluders("render", args, scene, quiet, &err)) != VDBS_OK ||
        (st = vdbs_options_max_memory(args, &q->desc.max_memory, &err)) != VDBS_OK)
        status = vdbs_command_fail("render", st, err.message);
    const char *input = args->positional_count ? args->positional[0] : scene->volume_file;
    if (status == VDBS_EXIT_OK && r->mode != VDBS_RENDER_REFERENCE) {
        static const char *const ref_only[] = {"--spp",  "--time",    "--tolerance",
                                               "--seed", "--env-nee", "--max-bounces"};
        for (int i = 0; i < 6; ++i)
            if (vdbs_options_value(args, ref_only[i]))
                warn_line(quiet, "%s applies to --mode reference only; ignored", ref_only[i]);
    }
    vdbs_render_desc *desc = &q->desc;
    desc->scene = scene;
    desc->scene_set = vdbs_options_scene_flags(args);
    desc->mode = r->mode;
    desc->backend = r->backend;
    desc->s1_march = r->s1_march;
    desc->s1_oversample = r->s1_oversample;
    desc->relight = r->relight;
    desc->camera = r->camera.present ? &r->camera : NULL;
    desc->width = r->size_given ? r->width : 0;
    desc->height = r->size_given ? r->height : 0;
    desc->exposure = r->exposure;
    desc->spp = (int)r->spp;
    desc->time_limit = r->time_limit;
    desc->tolerance = r->tolerance;
    desc->max_bounces = (int)r->max_bounces;
    desc->seed = r->seed;
    desc->no_env_nee = r->no_env_nee;
    desc->progress = !quiet && vdbs_command_progress();
    desc->warn = vdbs_command_warn;
    desc->cancel = vdbs_command_cancel();
    if (status == VDBS_EXIT_OK && vdbs_sequence_requested(args, input, r->output))
        status = run_sequence(q, input);
    else if (status == VDBS_EXIT_OK &&
             (status = vdbs_sequence_refuse_flags("render", args, NULL)) == VDBS_EXIT_OK)
        status = render_one(q, input, r->output, NULL);
    free(scene); /* after the report: input may be scene->volume_file */
    free(q);
    return status;
}

const vdbs_command_spec *vdbs_command_render(void)
{
    return &command;
}
