/* vdbscatter tradeoff IN.vdb -o DIR: every method over a quality ladder against a cached
 * Monte-Carlo reference of the same view (vdbscatter/tradeoff.h). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "options.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/tradeoff.h"

static const char help[] =
    "usage: vdbscatter tradeoff IN.vdb -o DIR [options]\n"
    "\n"
    "Measures the speed/accuracy trade on your scene and view: bakes every method at\n"
    "every quality of the ladder, renders each lit VDB, and compares the picture with a\n"
    "Monte-Carlo reference of the same view. The reference is rendered once to a noise\n"
    "target and cached in DIR under a key of the resolved scene, so a rerun reuses it;\n"
    "its own error at fewer samples per pixel is measured beside the methods.\n"
    "Writes DIR/tradeoff.csv, DIR/tradeoff.md (the cheapest setting per error level),\n"
    "DIR/tradeoff.png (error against seconds, log axes, the Pareto front marked) and\n"
    "DIR/images/METHOD-QUALITY.exr.\n"
    "\n"
    "scene (as for bake and render):\n"
    "  --scene FILE.json        scene file (volume, lights, camera)\n"
    "  --grid NAME[@INDEX]      density grid (default: density, or the only float grid)\n"
    "  --density-scale S        sigma_t = density * S, or auto:TAU\n"
    "  --albedo A | R,G,B       single-scattering albedo (default 0.5)\n"
    "  --g G                    Henyey-Greenstein anisotropy (default 0)\n"
    "  --sun DX,DY,DZ[:R,G,B]   sun travelling along D with irradiance RGB\n"
    "  --point X,Y,Z[:R,G,B]    point light with intensity RGB W/sr\n"
    "  --env R,G,B | FILE[:S]   constant sky radiance or a lat-long map\n"
    "  --camera PX,PY,PZ:TX,TY,TZ:FOV   the view (default: the scene's, else the whole\n"
    "                           volume from +Z)\n"
    "\n"
    "the measurement:\n"
    "  --methods A,B,...        methods to run (default: all of them)\n"
    "  --qualities Q,...        the steps of the ladder (default low,medium,high; ultra\n"
    "                           on request)\n"
    "  --size WxH               image size (default 128x96)\n"
    "  --ref-noise E            the reference's relative standard error (default 0.01)\n"
    "  --ref-time SECONDS       at most this long for the reference (default 600)\n"
    "  --seed S                 the reference's random seed (default 1)\n"
    "\n"
    "other options:\n"
    "  -o, --output DIR         the folder to write (created)\n"
    "  --backend auto|cpu|gpu   for the bakes and renders (the reference runs on the C "
    "path)\n" VDBS_OPTIONS_MAX_MEMORY_HELP
    "                           (each bake and render; one over it stops the run)\n"
    "  --json                   print the table as JSON on stdout\n"
    "  -q                       no progress, summary or warnings\n" VDBS_OPTIONS_RUN_HELP;

static const vdbs_arg_option options[] = {
    {"-o", VDBS_ARG_VALUE},
    {"--output", VDBS_ARG_VALUE},
    {"--backend", VDBS_ARG_VALUE},
    {"--json", VDBS_ARG_FLAG},
    {"-q", VDBS_ARG_FLAG},
    {"--scene", VDBS_ARG_VALUE},
    {"--grid", VDBS_ARG_VALUE},
    {"--density-scale", VDBS_ARG_VALUE},
    {"--albedo", VDBS_ARG_VALUE},
    {"--g", VDBS_ARG_VALUE},
    {"--sun", VDBS_ARG_LIST},
    {"--point", VDBS_ARG_LIST},
    {"--env", VDBS_ARG_LIST},
    {"--camera", VDBS_ARG_VALUE},
    {"--methods", VDBS_ARG_VALUE},
    {"--qualities", VDBS_ARG_VALUE},
    {"--size", VDBS_ARG_VALUE},
    {"--ref-noise", VDBS_ARG_VALUE},
    {"--ref-time", VDBS_ARG_VALUE},
    {"--seed", VDBS_ARG_VALUE},
    {"--max-memory", VDBS_ARG_VALUE},
    {NULL, VDBS_ARG_FLAG},
};

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .run = run,
    .name = "tradeoff",
    .options = options,
    .help = help,
    .max_positional = 1,
    .positional_error = "expected one input VDB",
};

/* "A,B,C" into names (pointing into buf). */
static vdbs_status split_list(const char *flag, const char *text, char *buf, size_t size,
                              const char **names, int max, int *count, vdbs_error *err)
{
    snprintf(buf, size, "%s", text);
    *count = 0;
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (*count == max)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: at most %d names", flag, max);
        names[(*count)++] = t;
    }
    if (*count == 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected a comma-separated list", flag);
    return VDBS_OK;
}

static vdbs_status parse(const vdbs_options_args *args, vdbs_tradeoff_desc *d, vdbs_camera *camera,
                         char *methods_buf, size_t methods_size, vdbs_error *err)
{
    vdbs_status st;
    const char *v;
    if ((v = vdbs_options_value(args, "--methods")) &&
        (st = split_list("--methods", v, methods_buf, methods_size, d->methods,
                         VDBS_TRADEOFF_MAX_METHODS, &d->method_count, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--qualities"))) {
        char buf[128];
        const char *names[VDBS_QUALITY_COUNT];
        int n;
        if ((st = split_list("--qualities", v, buf, sizeof buf, names, VDBS_QUALITY_COUNT, &n,
                             err)) != VDBS_OK)
            return st;
        for (int i = 0; i < n; ++i) {
            if (!vdbs_quality_find(names[i]))
                return vdbs_error_set(err, VDBS_ERR_INPUT,
                                      "--qualities: unknown quality '%s' (low, medium, high, "
                                      "ultra)",
                                      names[i]);
            d->qualities |= 1u << vdbs_quality_level(names[i]);
        }
    }
    if ((v = vdbs_options_value(args, "--size")) &&
        (st = vdbs_options_size(v, &d->width, &d->height, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--ref-noise"))) {
        if ((st = vdbs_options_number("--ref-noise", v, &d->ref_noise, err)) != VDBS_OK)
            return st;
        if (!(d->ref_noise > 0.0 && d->ref_noise < 1.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--ref-noise: expected 0 < E < 1, got '%s'",
                                  v);
    }
    if ((v = vdbs_options_value(args, "--ref-time"))) {
        if ((st = vdbs_options_number("--ref-time", v, &d->ref_seconds, err)) != VDBS_OK)
            return st;
        if (!(d->ref_seconds > 0.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--ref-time: expected seconds > 0, got '%s'",
                                  v);
    }
    if ((v = vdbs_options_value(args, "--seed"))) {
        long seed;
        if ((st = vdbs_options_integer("--seed", v, 0, 2147483647L, &seed, err)) != VDBS_OK)
            return st;
        d->seed = (uint64_t)seed;
    } else {
        d->seed = 1;
    }
    if ((v = vdbs_options_value(args, "--camera"))) {
        if ((st = vdbs_options_camera(v, camera, err)) != VDBS_OK)
            return st;
        d->camera = camera;
    }
    if ((v = vdbs_options_value(args, "--backend")) &&
        (st = vdbs_backend_parse(v, &d->backend, err)) != VDBS_OK)
        return st;
    return vdbs_options_max_memory(args, &d->max_memory, err);
}

static void print_json(const vdbs_tradeoff_report *rep)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "width", rep->width);
    cJSON_AddNumberToObject(j, "height", rep->height);
    cJSON *r = cJSON_AddObjectToObject(j, "reference");
    cJSON_AddStringToObject(r, "key", rep->key);
    cJSON_AddBoolToObject(r, "cached", rep->reference_cached);
    cJSON_AddNumberToObject(r, "spp", rep->reference_spp);
    cJSON_AddNumberToObject(r, "seconds", rep->reference_seconds);
    cJSON_AddNumberToObject(r, "noise", rep->reference_noise);
    cJSON *curve = cJSON_AddArrayToObject(r, "curve");
    for (int i = 0; i < rep->curve_count; ++i) {
        cJSON *p = cJSON_CreateObject();
        cJSON_AddNumberToObject(p, "spp", rep->curve[i].spp);
        cJSON_AddNumberToObject(p, "seconds", rep->curve[i].seconds);
        cJSON_AddNumberToObject(p, "relrmse", rep->curve[i].relrmse);
        cJSON_AddItemToArray(curve, p);
    }
    cJSON *rows = cJSON_AddArrayToObject(j, "rows");
    for (int i = 0; i < rep->row_count; ++i) {
        const vdbs_tradeoff_row *w = &rep->rows[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "method", w->method);
        cJSON_AddStringToObject(o, "quality", w->quality);
        cJSON_AddNumberToObject(o, "bake_s", w->seconds_bake);
        cJSON_AddNumberToObject(o, "render_s", w->seconds_render);
        cJSON_AddNumberToObject(o, "peak_mib", w->peak_mib);
        cJSON_AddNumberToObject(o, "relrmse", w->relrmse);
        cJSON_AddNumberToObject(o, "relrmse_se", w->relrmse_se);
        cJSON_AddNumberToObject(o, "mean_ratio", w->mean_ratio);
        cJSON_AddBoolToObject(o, "pareto", w->pareto);
        cJSON_AddItemToArray(rows, o);
    }
    cJSON *files = cJSON_AddObjectToObject(j, "files");
    cJSON_AddStringToObject(files, "csv", rep->csv);
    cJSON_AddStringToObject(files, "markdown", rep->markdown);
    cJSON_AddStringToObject(files, "plot", rep->plot);
    cJSON_AddNumberToObject(j, "seconds", rep->seconds_total);
    char *text = cJSON_Print(j);
    vdbs_command_out("%s\n", text);
    free(text);
    cJSON_Delete(j);
}

static int run(const vdbs_options_args *args)
{
    vdbs_error err;
    vdbs_status st;
    const char *out = vdbs_options_output(args);
    if (!out)
        return vdbs_command_fail("tradeoff", 2, "missing -o DIR");
    vdbs_tradeoff_desc d = {0};
    vdbs_camera camera;
    char methods[512];
    if ((st = parse(args, &d, &camera, methods, sizeof methods, &err)) != VDBS_OK)
        return vdbs_command_fail("tradeoff", st, err.message);
    vdbs_scene *scene = malloc(sizeof *scene);
    if (!scene)
        return vdbs_command_fail("tradeoff", 1, "out of memory");
    if ((st = vdbs_options_build_scene(args, scene, 0, &err)) != VDBS_OK) {
        free(scene);
        return vdbs_command_fail("tradeoff", st, err.message);
    }
    d.input = args->positional_count ? args->positional[0] : scene->volume_file;
    if (!d.input[0]) {
        free(scene);
        return vdbs_command_fail("tradeoff", 2,
                                 "no input VDB (give IN.vdb or volume.file in --scene)");
    }
    int quiet = vdbs_options_flag(args, "-q");
    d.scene = scene;
    d.dir = out;
    d.progress = !quiet && vdbs_command_progress();
    d.warn = vdbs_command_warn;
    d.warn_user = &quiet;
    d.cancel = vdbs_command_cancel();
    vdbs_tradeoff_report rep;
    st = vdbs_tradeoff_run(&d, &rep, &err);
    free(scene);
    if (st != VDBS_OK) {
        vdbs_tradeoff_report_free(&rep);
        return st == VDBS_ERR_CANCELLED ? vdbs_command_interrupted("tradeoff", VDBS_EXIT_FAILURE)
                                        : vdbs_command_fail("tradeoff", st, err.message);
    }
    if (vdbs_options_flag(args, "--json"))
        print_json(&rep);
    else if (!quiet)
        vdbs_command_out(
            "tradeoff: %d runs against a %d-spp reference (noise %.4f%s) in %.1f s: %s\n",
            rep.row_count, rep.reference_spp, rep.reference_noise,
            rep.reference_cached ? ", cached" : "", rep.seconds_total, rep.markdown);
    vdbs_tradeoff_report_free(&rep);
    return vdbs_command_interrupted("tradeoff", VDBS_EXIT_OK);
}

const vdbs_command_spec *vdbs_command_tradeoff(void)
{
    return &command;
}
