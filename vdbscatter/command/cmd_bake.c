/* vdbscatter bake IN.vdb -o OUT.vdb|OUT.nvdb: light a density volume and write a lit VDB. */
#define _XOPEN_SOURCE 700
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "vdbscatter/message.h"
#include "vdbscatter/tempfile.h"
#include "vdbscatter/litvdb.h"

#include "commands.h"
#include "options.h"
#include "sequence.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/plan.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/scene_file.h"

static const char help[] =
    "usage: vdbscatter bake IN.vdb -o OUT.vdb|OUT.nvdb [options]\n"
    "       vdbscatter bake IN.####.vdb -o OUT.####.vdb [--frames 1-240] [options]\n"
    "\n"
    "Computes the in-scattered radiance of sun, point and sky lights in a density\n"
    "volume and writes a lit VDB with grids density, radiance, ms, ms_l1x, ms_l1y,\n"
    "ms_l1z (use sigma_s * radiance as emission in any renderer), and radiance_view,\n"
    "the radiance scattered toward the camera, when the scene has one.\n"
    "\n"
    "scene (flags override --scene; light flags replace the scene's lights):\n"
    "  --scene FILE.json        scene file (volume, lights, camera, solver)\n"
    "  --grid NAME[@INDEX]      density grid (default: density, or the only float grid)\n"
    "  --density-scale S        sigma_t = density * S (per world unit; default 1), or\n"
    "                           auto:TAU for a mean optical depth TAU through the volume\n"
    "                           (clouds look like clouds at about 5-20; see info --target-depth)\n"
    "  --albedo A | R,G,B       single-scattering albedo (default 0.5)\n"
    "  --g G                    Henyey-Greenstein anisotropy in [-0.999, 0.999] (default 0)\n"
    "  --sun DX,DY,DZ[:R,G,B]   sun travelling along D with irradiance RGB (default 1)\n"
    "  --point X,Y,Z[:R,G,B]    point light at X,Y,Z with intensity RGB W/sr (default 1)\n"
    "  --env R,G,B | FILE[:S]   constant sky radiance, or a lat-long OpenEXR / Radiance HDR\n"
    "                           map times S, importance-sampled into the sky directions\n"
    "  --sky-directions K       sky quadrature directions (default: the quality's)\n"
    "  --method NAME            solver (default svd: the lowest measured error for its\n"
    "                           time on general volumes; the list below), or auto: the\n"
    "                           planner picks the method, quality and lights for --tolerance\n"
    "  --tolerance E            with --method auto: the image relative RMSE you accept\n"
    "                           (default 0.1); where no plan is predicted to reach it,\n"
    "                           the most accurate one is baked and a warning names it\n"
    "  --dry-run                with --method auto: print the plan and its predictions\n"
    "                           (with --json as JSON) and bake nothing\n"
    "  --calibration-leave-out SCENE   with --dry-run: plan as if the calibration scene\n"
    "                           SCENE were not in the planner's table (measures the\n"
    "                           planner on scenes it has not seen)\n"
    "  --camera PX,PY,PZ:TX,TY,TZ:FOV   the camera radiance_view is written toward\n"
    "  --quality Q              low (default) | medium | high | ultra (sky directions\n"
    "                           16/64/256/1024, POP 16 at all, SVD 64 at high and\n"
    "                           ultra; and each method's defaults below; pop and inet\n"
    "                           bake every quality as low)\n"
    "  --keep-state             a method with state (svd, fld, inet) also writes it into\n"
    "                           the lit VDB (svd: the N radiance moment grids svd_m0000...;\n"
    "                           fld: the fluence grid fld_phi; inet: per direction the RGB\n"
    "                           slot radiance, a voxel's particles' mean, inet_r0000...)\n"
    "  --warm-start FILE.vdb    start from a --keep-state bake's state (svd: its moments,\n"
    "                           its D and N; fld: its fluence, for the first solve and\n"
    "                           limiter; inet: each particle from its voxel's radiance, the\n"
    "                           same D), read where the volume's voxels are in the world\n"
    "\n"
    "other options:\n"
    "  -o, --output FILE        lit VDB to write (refused if equal to the input): FILE.vdb\n"
    "                           (OpenVDB) or FILE.nvdb (NanoVDB, the same grids as float /\n"
    "                           Vec3f, plus FILE.nvdb.json holding the metadata)\n"
    "  --backend auto|cpu|gpu   auto: a hardware GPU if EGL finds one, else the C "
    "path\n" VDBS_OPTIONS_S1_HELP
    "  --s1-sky-spacing S       sky directions' light-grid spacing in smallest voxel\n"
    "                           lengths (default: by the sky's share of the light, from\n"
    "                           the suns' spacing up to 4; docs/design.md)\n"
    "  --from-levelset          convert a level set to a fog volume instead of refusing it\n"
    "  --half                   store grids as half floats (values clamped to 65504)\n"
    "  --store lights|none      lights (default): also store the optical depth toward every\n"
    "                           light and sky direction, so that renders of the lit VDB\n"
    "                           need no light sweeps (docs/lit-vdb.md); none: radiance and\n"
    "                           the multiple-scattering grids only\n" VDBS_OPTIONS_MAX_MEMORY_HELP
    "  --report FILE.json       write timings per stage, parameters, output grids and\n"
    "                           memory (the estimate and each stage's peak); for a\n"
    "                           sequence one per frame: FILE.####.json\n"
    "  --json                   print the report as JSON on stdout\n"
    "  -q                       no progress, summary or warnings\n" VDBS_OPTIONS_RUN_HELP "\n"
    "frame sequences (docs/sequences.md): a frame number in IN and -o, as ####\n"
    "(padded to the count of #), $F or $F4 (Houdini), or %d or %04d:\n"
    "  --frames LIST            1-240, 1-240x2 (every 2nd), 1,5,9, or a mix; default:\n"
    "                           the input frames on disk\n"
    "  --skip-missing           bake the frames whose input is there (default: refuse\n"
    "                           the sequence, listing the missing ones)\n"
    "  --fps R                  the frame rate, into each output's metadata\n"
    "  --force                  bake every frame (default: skip a frame whose output\n"
    "                           carries the hash of this bake's scene, options, tool\n"
    "                           version and input)\n"
    "  --hash-inputs            the input's identity in the hash is its bytes' hash\n"
    "                           (default: its size and modification time)\n"
    "  --verify                 bake nothing: check that every frame is done with this\n"
    "                           bake's hash (exit 0, else 3)\n"
    "  --summary FILE.json      the sequence summary, rewritten after every frame\n"
    "  --no-warm-start          start svd and fld cold on every frame (default: from\n"
    "                           the previous frame's state, kept in its .vdb; inet's only\n"
    "                           with --keep-state)\n"
    "exit status: 0 done, 1 failure, 2 bad input, 3 a sequence done in part\n";

static const vdbs_arg_option own_options[] = {
    VDBS_OPTIONS_COMMON,
    {"--from-levelset", VDBS_ARG_FLAG},
    {"--half", VDBS_ARG_FLAG},
    {"--report", VDBS_ARG_VALUE},
    {"--method", VDBS_ARG_VALUE},
    {"--keep-state", VDBS_ARG_FLAG},
    {"--warm-start", VDBS_ARG_VALUE},
    {"--camera", VDBS_ARG_VALUE},
    {"--store", VDBS_ARG_VALUE},
    {"--tolerance", VDBS_ARG_VALUE},
    {"--dry-run", VDBS_ARG_FLAG},
    {"--calibration-leave-out", VDBS_ARG_VALUE},
    {"--s1-sky-spacing", VDBS_ARG_VALUE},
    {"--max-memory", VDBS_ARG_VALUE},
    VDBS_SEQUENCE_OPTIONS,
    {"--force", VDBS_ARG_FLAG},
    {"--verify", VDBS_ARG_FLAG},
    {"--hash-inputs", VDBS_ARG_FLAG},
    {"--no-warm-start", VDBS_ARG_FLAG},
};

static vdbs_arg_option all_options[VDBS_OPTIONS_MAX];

static void fill_options(void)
{
    const int own = (int)(sizeof own_options / sizeof own_options[0]);
    memcpy(all_options, own_options, sizeof own_options);
    vdbs_options_add_solver_flags(all_options, own, VDBS_OPTIONS_MAX);
}

/* The light grids' sizes and times per kind of light (those with lights). */
static cJSON *kinds_json(const vdbs_s1_kind_stats kinds[VDBS_S1_KINDS])
{
    static const char *names[VDBS_S1_KINDS] = {"sun", "point", "sky"};
    cJSON *a = cJSON_CreateArray();
    for (int k = 0; k < VDBS_S1_KINDS; ++k) {
        const vdbs_s1_kind_stats *s = &kinds[k];
        if (s->lights == 0)
            continue;
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "kind", names[k]);
        cJSON_AddNumberToObject(o, "lights", s->lights);
        cJSON_AddNumberToObject(o, "spacing_min", s->grids.spacing_min);
        cJSON_AddNumberToObject(o, "spacing_max", s->grids.spacing_max);
        cJSON_AddNumberToObject(o, "cells", (double)s->grids.cells);
        cJSON_AddNumberToObject(o, "columns", (double)s->grids.columns);
        cJSON_AddNumberToObject(o, "samples_stored", (double)s->grids.stored);
        cJSON_AddNumberToObject(o, "seconds_sweep", s->grids.seconds_sweep);
        cJSON_AddNumberToObject(o, "seconds_lookup", s->seconds_lookup);
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

static cJSON *report_json(const char *input, const char *output, const vdbs_scene *scene,
                          const vdbs_bake_report *r)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "input", input);
    cJSON_AddStringToObject(j, "output", output);
    cJSON_AddStringToObject(j, "grid", r->grid);
    cJSON_AddStringToObject(j, "method", scene->method);
    cJSON_AddStringToObject(j, "quality", scene->quality);
    if (r->quality_baked[0] && strcmp(r->quality_baked, scene->quality) != 0)
        cJSON_AddStringToObject(j, "quality_baked", r->quality_baked);
    cJSON_AddNumberToObject(j, "sky_directions", r->sky_directions);
    cJSON_AddStringToObject(j, "s1", r->s1);
    if (r->s1_oversample > 0)
        cJSON_AddNumberToObject(j, "s1_oversample", r->s1_oversample);
    cJSON_AddStringToObject(j, "backend", r->backend);
    cJSON_AddStringToObject(j, "renderer", r->renderer);
    cJSON_AddNumberToObject(j, "active_voxels", (double)r->active_voxels);
    cJSON_AddNumberToObject(j, "output_voxels", (double)r->output_voxels);
    cJSON *moved = cJSON_AddObjectToObject(j, "transfer");
    cJSON_AddNumberToObject(moved, "uploaded_bytes", (double)r->bytes_uploaded);
    cJSON_AddNumberToObject(moved, "read_back_bytes", (double)r->bytes_read_back);
    cJSON *t = cJSON_AddObjectToObject(j, "seconds");
    cJSON_AddNumberToObject(t, "load", r->seconds_load);
    cJSON_AddNumberToObject(t, "solve", r->seconds_solve);
    cJSON_AddNumberToObject(t, "write", r->seconds_write);
    cJSON_AddNumberToObject(t, "total", r->seconds_total);
    if (r->s1_oversample > 0) {
        cJSON_AddNumberToObject(t, "s1_sweep", r->s1_grids.seconds_sweep);
        cJSON_AddNumberToObject(t, "s1_lookup", r->seconds_s1_lookup);
        vdbs_options_json_light_grids(j, &r->s1_grids);
        cJSON_AddItemToObject(j, "s1_grids_per_kind", kinds_json(r->s1_kinds));
    }
    const vdbs_solver *solver = vdbs_solver_find(scene->method);
    if (solver)
        vdbs_solver_report_json(solver, scene, vdbs_bake_report_stats(r), t, j);
    double rmax[3] = {r->radiance_max[0], r->radiance_max[1], r->radiance_max[2]};
    cJSON_AddItemToObject(j, "radiance_max", vdbs_options_json_triple(rmax));
    const char *grids[] = {"density", "radiance", "ms",           "ms_l1x",
                           "ms_l1y",  "ms_l1z",   "radiance_view"};
    cJSON *names = cJSON_CreateStringArray(grids, scene->camera.present ? 7 : 6);
    cJSON_AddItemToObject(j, "grids", names);
    for (int i = 0; i < r->stored_direct + r->stored_sky; ++i) {
        char name[32];
        vdbs_lit_depth_name(i, r->stored_direct, name, sizeof name);
        cJSON_AddItemToArray(names, cJSON_CreateString(name));
    }
    cJSON_AddStringToObject(j, "store", r->stored_direct + r->stored_sky ? "lights" : "none");
    const char *const stages[] = {"load", "solve", "write"};
    const int64_t peaks[] = {r->peak_load, r->peak_solve, r->peak_write};
    vdbs_options_json_memory(j, r->memory_limit, r->memory_baseline, &r->memory_estimate, stages,
                             peaks, 3, r->peak_per_stage);
    if (r->planned) {
        char *plan = vdbs_plan_json(&r->plan, &r->plan_features);
        cJSON *p = plan ? cJSON_Parse(plan) : NULL;
        free(plan);
        if (p)
            cJSON_AddItemToObject(j, "plan", p);
    }
    char *scene_text = vdbs_scene_to_json(scene);
    cJSON *parsed = scene_text ? cJSON_Parse(scene_text) : NULL;
    free(scene_text);
    if (parsed)
        cJSON_AddItemToObject(j, "scene", parsed);
    return j;
}

/* The report: into --report's file, as OUTPUT with --json, else a summary NOTE unless
 * -q. Returns the exit status (1 when the --report file cannot be written). */
static int print_report(const vdbs_options_args *args, cJSON *j, const vdbs_scene *scene,
                        const vdbs_bake_report *report, const char *out)
{
    const char *report_path = vdbs_options_value(args, "--report");
    int status = VDBS_EXIT_OK;
    if (report_path) {
        char *text = cJSON_Print(j);
        vdbs_text_file file;
        vdbs_error err;
        vdbs_status st = text ? vdbs_text_begin(&file, report_path, &err) : VDBS_ERR_NOMEM;
        if (st == VDBS_OK) {
            fputs(text, file.stream);
            fputc('\n', file.stream);
            st = vdbs_text_commit(&file, &err);
        }
        if (st != VDBS_OK)
            status = vdbs_command_fail("bake", 1, text ? err.message : "out of memory");
        free(text);
    }
    if (vdbs_options_flag(args, "--json")) {
        char *text = cJSON_Print(j);
        vdbs_command_out("%s\n", text);
        free(text);
    } else if (!vdbs_options_flag(args, "-q")) {
        vdbs_message_emitf(
            VDBS_MESSAGE_NOTE,
            "baked %llu voxels of '%s' (%s, quality %s) on %s in %.2fs (solve %.2fs) -> %s\n",
            report->output_voxels, report->grid, scene->method, scene->quality, report->backend,
            report->seconds_total, report->seconds_solve, out);
        const vdbs_solver *solver = vdbs_solver_find(scene->method);
        if (solver && solver->report_text) {
            char text[256];
            solver->report_text(vdbs_bake_report_stats(report), text, sizeof text);
            vdbs_message_emitf(VDBS_MESSAGE_NOTE, "  %s: %s\n", solver->name, text);
        }
    }
    return status;
}

/* --dry-run: the plan as OUTPUT, as JSON with --json. */
static int print_plan(const vdbs_options_args *args, const vdbs_bake_report *report)
{
    char *text = vdbs_plan_json(&report->plan, &report->plan_features);
    cJSON *plan = text ? cJSON_Parse(text) : NULL;
    free(text);
    if (!plan)
        return vdbs_command_fail("bake", 1, "out of memory");
    if (vdbs_options_flag(args, "--json")) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddItemToObject(j, "plan", plan);
        char *out = cJSON_Print(j);
        vdbs_command_out("%s\n", out);
        free(out);
        cJSON_Delete(j);
        return VDBS_EXIT_OK;
    }
    const vdbs_plan *p = &report->plan;
    const vdbs_plan_features *f = &report->plan_features;
    vdbs_command_out(
        "scene: mean optical depth %.3g, albedo %.3g, g %.2f, ms/ss %.2g, %.0f voxels, sky "
        "share %.2f, point share %.2f\n",
        f->mean_depth, f->albedo, f->g, f->ms_to_ss, f->active_voxels, f->sky_share,
        f->point_share);
    vdbs_command_out("%-8s %-8s %12s %12s\n", "method", "quality", "pred. error", "cost hint s");
    int count;
    const vdbs_quality *q = vdbs_quality_list(&count);
    for (int i = 0; i < p->candidate_count; ++i) {
        const vdbs_plan_candidate *c = &p->candidates[i];
        vdbs_command_out("%-8s %-8s %12.4f %12.2f%s\n", c->method, q[c->quality].name, c->error,
                         c->seconds,
                         strcmp(c->method, p->chosen.method) == 0 && c->quality == p->chosen.quality
                             ? "  <- plan"
                             : "");
    }
    for (int i = 0; i < f->light_count; ++i)
        if (p->skip[i])
            vdbs_command_out("light %d left out: %.2g of the power\n", i, f->light_share[i]);
    if (p->reachable)
        vdbs_command_out(
            "plan: --method %s --quality %s, predicted error %.3g (tolerance %g), cost "
            "hint %.1f s\n",
            p->chosen.method, q[p->chosen.quality].name, p->chosen.error, p->tolerance,
            p->chosen.seconds);
    else
        vdbs_command_out("tolerance %g is out of reach: the best predicted is %.3g (--method %s "
                         "--quality %s, cost hint %.1f s)\n",
                         p->tolerance, p->chosen.error, p->chosen.method, q[p->chosen.quality].name,
                         p->chosen.seconds);
    cJSON_Delete(plan);
    return VDBS_EXIT_OK;
}

/* After the help: the methods and their options, from the solver table. */
static void print_solver_help(void)
{
    vdbs_options_solver_help();
}

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .name = "bake",
    .run = run,
    .options = all_options,
    .help = help,
    .more_help = print_solver_help,
    .max_positional = 1,
    .positional_error = "expected one input VDB",
};

/* What every frame of a bake shares: the scene, the options, and the sequence flags. */
typedef struct bake_request {
    const vdbs_options_args *args;
    vdbs_scene scene; /* volume_file: the input (a pattern for a sequence) */
    vdbs_bake_options options;
    const char *out;
    int quiet;
    int sequence_warm; /* a sequence's frames warm-start from the previous frame's state */
    int hash_inputs;
    const char *backend;
} bake_request;

/* The words into the request (everything but the frame's input and output). */
static int prepare(const vdbs_options_args *args, bake_request *r)
{
    vdbs_error err;
    vdbs_status st;
    memset(r, 0, sizeof *r);
    r->args = args;
    const char *out = r->out = vdbs_options_output(args);
    if (!out)
        return vdbs_command_fail("bake", 2, "missing -o OUT.vdb");
    vdbs_scene *scene = &r->scene;
    struct stat out_stat;
    int out_is_dir = stat(out, &out_stat) == 0 && S_ISDIR(out_stat.st_mode);
    /* a folder: the write says so */
    if (!out_is_dir && !vdbs_options_has_extension(out, ".vdb") &&
        !vdbs_options_has_extension(out, ".nvdb"))
        return vdbs_command_fail("bake", 2, "-o: expected .vdb or .nvdb");
    /* Lights are checked after the input file and grid (vdbs_bake), so that a missing file is
     * not reported as a missing light. */
    if ((st = vdbs_options_build_scene(args, scene, 1, &err)) != VDBS_OK)
        return vdbs_command_fail("bake", st, err.message);
    if ((st = vdbs_options_scene_occluders("bake", args, scene, vdbs_options_flag(args, "-q"),
                                           &err)) != VDBS_OK)
        return vdbs_command_fail("bake", st, err.message);
    const char *camera = vdbs_options_value(args, "--camera");
    if (camera) {
        vdbs_camera c;
        if ((st = vdbs_options_camera(camera, &c, &err)) != VDBS_OK)
            return vdbs_command_fail("bake", st, err.message);
        /* The render of the lit VDB frames with it: keep the scene's size, else the render's
         * default. */
        c.width = scene->camera.present ? scene->camera.width : 640;
        c.height = scene->camera.present ? scene->camera.height : 480;
        scene->camera = c;
    }
    /* IN.vdb overrides the scene file's volume, in the bake and in the scene it records. */
    if (args->positional_count) {
        if (strlen(args->positional[0]) >= sizeof scene->volume_file)
            return vdbs_command_fail("bake", 2, "IN.vdb: the path is too long");
        snprintf(scene->volume_file, sizeof scene->volume_file, "%s", args->positional[0]);
    }
    if (!scene->volume_file[0])
        return vdbs_command_fail("bake", 2, "no input VDB (give IN.vdb or volume.file in --scene)");
    vdbs_bake_options *o = &r->options;
    o->scene = scene;
    r->backend = vdbs_options_value(args, "--backend");
    if (r->backend && (st = vdbs_backend_parse(r->backend, &o->backend, &err)) != VDBS_OK)
        return vdbs_command_fail("bake", st, err.message);
    int quiet = r->quiet = vdbs_options_flag(args, "-q");
    if ((st = vdbs_options_s1(args, &o->s1_march, &o->s1_oversample, &err)) != VDBS_OK)
        return vdbs_command_fail("bake", st, err.message);
    const char *sky_spacing = vdbs_options_value(args, "--s1-sky-spacing");
    if (sky_spacing) {
        if ((st = vdbs_options_number("--s1-sky-spacing", sky_spacing, &o->s1_sky_spacing, &err)) !=
            VDBS_OK)
            return vdbs_command_fail("bake", st, err.message);
        if (!(o->s1_sky_spacing > 0.0 && o->s1_sky_spacing <= 64.0))
            return vdbs_command_fail("bake", 2, "--s1-sky-spacing: expected a number in (0, 64]");
    }
    o->from_levelset = vdbs_options_flag(args, "--from-levelset");
    o->half = vdbs_options_flag(args, "--half");
    const char *store = vdbs_options_value(args, "--store");
    if (store && strcmp(store, "lights") != 0 && strcmp(store, "none") != 0)
        return vdbs_command_fail("bake", 2, "--store: expected lights or none");
    o->store = store && strcmp(store, "none") == 0 ? VDBS_STORE_NONE : VDBS_STORE_LIGHTS;
    const char *method = vdbs_options_value(args, "--method");
    const char *tolerance = vdbs_options_value(args, "--tolerance");
    int automatic = method && strcmp(method, "auto") == 0;
    if (tolerance && !automatic)
        return vdbs_command_fail("bake", 2, "--tolerance needs --method auto");
    o->dry_run = vdbs_options_flag(args, "--dry-run");
    if (o->dry_run && !automatic)
        return vdbs_command_fail("bake", 2, "--dry-run needs --method auto");
    o->plan_leave_out = vdbs_options_value(args, "--calibration-leave-out");
    if (o->plan_leave_out && !o->dry_run)
        return vdbs_command_fail("bake", 2, "--calibration-leave-out needs --dry-run");
    if (automatic) {
        o->tolerance = 0.1;
        if (tolerance &&
            (st = vdbs_options_number("--tolerance", tolerance, &o->tolerance, &err)) != VDBS_OK)
            return vdbs_command_fail("bake", st, err.message);
        if (!(o->tolerance > 0.0 && o->tolerance < 1.0))
            return vdbs_command_fail("bake", 2, "--tolerance: expected a relative RMSE 0 < E < 1");
    }
    if ((st = vdbs_options_max_memory(args, &o->max_memory, &err)) != VDBS_OK)
        return vdbs_command_fail("bake", st, err.message);
    o->keep_state = vdbs_options_flag(args, "--keep-state");
    o->warm_start = vdbs_options_value(args, "--warm-start");
    o->progress = !quiet && vdbs_command_progress();
    o->warn = vdbs_command_warn;
    o->warn_user = &r->quiet;
    o->cancel = vdbs_command_cancel();
    r->hash_inputs = vdbs_options_flag(args, "--hash-inputs");
    return VDBS_EXIT_OK;
}

/* A file's identity in the hash text: its size and modification time, or its bytes' hash. */
static int file_identity(const bake_request *r, const char *what, const char *path, FILE *text)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        fprintf(text, "%s %s: none\n", what, path);
        return VDBS_EXIT_OK;
    }
    if (r->hash_inputs) {
        char hash[VDBS_SEQUENCE_HASH_SIZE];
        vdbs_error err;
        if (vdbs_sequence_hash_file(path, hash, &err) != VDBS_OK)
            return vdbs_command_fail("bake", 2, err.message);
        fprintf(text, "%s %s: xxh3 %s\n", what, path, hash);
    } else {
        fprintf(text, "%s %s: %lld bytes, modified %lld.%09ld\n", what, path, (long long)st.st_size,
                (long long)st.st_mtim.tv_sec, st.st_mtim.tv_nsec);
    }
    return VDBS_EXIT_OK;
}

/* The determinants hash of the bake of `input` (docs/sequences.md, "Resumable"): the tool's
 * version, the resolved scene with its solver settings, the bake's options, the frame rate,
 * and the identity of the input and of every file the scene reads. */
static int request_hash(const bake_request *r, const char *input, double fps,
                        char hash[VDBS_SEQUENCE_HASH_SIZE])
{
    vdbs_scene scene = r->scene;
    /* The input by its real path: the same bake from another folder, or through a relative
     * path, is the same bake. */
    char *real = realpath(input, NULL);
    if (real)
        input = real;
    snprintf(scene.volume_file, sizeof scene.volume_file, "%s", input);
    char *scene_text = vdbs_scene_to_json(&scene);
    char *text = NULL;
    size_t length = 0;
    FILE *f = scene_text ? open_memstream(&text, &length) : NULL;
    if (!f) {
        free(scene_text);
        free(real);
        return vdbs_command_fail("bake", 1, "out of memory");
    }
    const vdbs_bake_options *o = &r->options;
    fprintf(f,
            "vdbscatter %s\n%s\ns1 march %d oversample %d sky spacing %.17g\nlevelset %d half %d "
            "store %d tolerance %.17g keep state %d backend %s fps %.17g\n",
            vdbs_version(), scene_text, o->s1_march, o->s1_oversample, o->s1_sky_spacing,
            o->from_levelset, o->half, (int)o->store, o->tolerance,
            o->keep_state || r->sequence_warm, r->backend ? r->backend : "auto", fps);
    free(scene_text);
    int status = file_identity(r, "input", input, f);
    /* the maps and meshes the scene reads */
    for (const char *p = r->scene.env_paths; status == VDBS_EXIT_OK && *p; p += strlen(p) + 1)
        status = file_identity(r, "map", p, f);
    for (const char *p = r->scene.occluder_paths; status == VDBS_EXIT_OK && *p; p += strlen(p) + 1)
        status = file_identity(r, "mesh", p, f);
    const int written = fclose(f) == 0;
    if (status == VDBS_EXIT_OK && !written)
        status = vdbs_command_fail("bake", 1, "out of memory");
    if (status == VDBS_EXIT_OK)
        vdbs_sequence_hash_text(text, hash);
    free(text);
    free(real);
    return status;
}

/* The frame's metadata: its hash always; with a sequence its number, rate and warm start. */
typedef struct frame_meta {
    char hash[VDBS_SEQUENCE_HASH_SIZE], frame[24], fps[32], warm[VDBS_SEQUENCE_PATH_MAX];
    vdbio_meta items[VDBS_BAKE_EXTRA_META_MAX];
    int count;
} frame_meta;

/* Bakes one input into one output; the report into *report_out (a sequence's frame), or
 * printed (a single bake). Returns the exit status. */
static int bake_one(bake_request *r, const vdbs_bake_options *options, const char *input,
                    const char *output, const frame_meta *meta, cJSON **report_out)
{
    const vdbs_options_args *args = r->args;
    vdbs_error err;
    vdbs_status st;
    vdbs_scene scene = r->scene;
    snprintf(scene.volume_file, sizeof scene.volume_file, "%s", input);
    vdbs_bake_options o = *options;
    o.input = input;
    o.output = output;
    o.scene = &scene;
    o.warn_user = &r->quiet;
    if (meta) {
        o.extra_meta = meta->items;
        o.extra_meta_count = meta->count;
    }
    vdbs_bake_report report;
    if ((st = vdbs_bake(&o, &report, &err)) != VDBS_OK)
        return st == VDBS_ERR_CANCELLED ? vdbs_command_interrupted("bake", VDBS_EXIT_FAILURE)
                                        : vdbs_command_fail("bake", st, err.message);

    if (o.dry_run)
        return print_plan(args, &report);
    /* The report's scene is the one baked: the plan's method, quality and lights. */
    if (report.planned && (st = vdbs_plan_apply(&report.plan, &scene, &err)) != VDBS_OK)
        return vdbs_command_fail("bake", st, err.message);
    double target_depth = scene.density_target_depth;
    scene.density_scale = report.density_scale; /* as resolved (auto:TAU) */
    scene.density_target_depth = 0.0;
    cJSON *j = report_json(input, output, &scene, &report);
    cJSON_AddNumberToObject(j, "density_scale", report.density_scale);
    if (target_depth > 0.0)
        cJSON_AddNumberToObject(j, "density_target_depth", target_depth);
    cJSON_AddNumberToObject(j, "mean_optical_depth", report.advice.mean_depth);
    cJSON_AddNumberToObject(j, "ms_to_ss_estimate", report.advice.ms_to_ss);
    if (meta) {
        cJSON_AddStringToObject(j, "hash", meta->hash);
        if (report_out) {
            cJSON_AddNumberToObject(j, "frame", strtod(meta->frame, NULL));
            cJSON_AddStringToObject(j, "warm_start_from", meta->warm);
        }
    }
    if (report_out) {
        *report_out = j;
        return VDBS_EXIT_OK;
    }
    int status = print_report(args, j, &scene, &report, output);
    cJSON_Delete(j);
    return vdbs_command_interrupted("bake", status); /* a signal after the new file was in place */
}

/* ---- sequences ---- */

static void meta_add(frame_meta *m, const char *key, const char *value)
{
    m->items[m->count++] = (vdbio_meta){key, value};
}

static int frame_hash(void *user, vdbs_sequence_frame *frame)
{
    return request_hash(user, frame->input, frame->fps, frame->hash);
}

static int frame_run(void *user, const vdbs_sequence_frame *frame, cJSON **report)
{
    bake_request *r = user;
    frame_meta meta = {0};
    snprintf(meta.hash, sizeof meta.hash, "%s", frame->hash);
    snprintf(meta.frame, sizeof meta.frame, "%ld", frame->frame);
    meta_add(&meta, VDBS_SEQUENCE_META_HASH, meta.hash);
    meta_add(&meta, VDBS_SEQUENCE_META_FRAME, meta.frame);
    if (frame->fps > 0.0) {
        snprintf(meta.fps, sizeof meta.fps, "%.17g", frame->fps);
        meta_add(&meta, VDBS_SEQUENCE_META_FPS, meta.fps);
    }
    /* Warm from the previous frame's file, never from memory: a run resumed after a kill
     * then bakes every frame from the same start as an uninterrupted one. */
    vdbs_bake_options options = r->options;
    if (r->sequence_warm) {
        options.keep_state = 1;
        options.warm_start = frame->previous_output;
        if (frame->previous_output) {
            const char *slash = strrchr(frame->previous_output, '/');
            snprintf(meta.warm, sizeof meta.warm, "%s", slash ? slash + 1 : frame->previous_output);
        }
        meta_add(&meta, "vdbscatter_warm_start", meta.warm);
    }
    return bake_one(r, &options, frame->input, frame->output, &meta, report);
}

/* bake's flags that only a sequence takes, beside the common ones (sequence.h). */
static const char *const own_sequence_flags[] = {"--force", "--verify", "--no-warm-start", NULL};

static int run_sequence(bake_request *r)
{
    const vdbs_options_args *args = r->args;
    if (r->options.dry_run)
        return vdbs_command_fail("bake", 2,
                                 "--dry-run plans one bake: give one input, not a "
                                 "sequence");
    const char *report = vdbs_options_value(args, "--report");
    vdbs_frame_token token;
    vdbs_error err;
    if (report &&
        (vdbs_frame_token_find(report, "--report", &token, &err) != VDBS_OK || !token.length))
        return vdbs_command_fail("bake", 2,
                                 token.length ? err.message
                                              : "--report: a sequence writes a report per "
                                                "frame: give a frame number (report.####.json)");
    const vdbs_solver *solver = vdbs_solver_find(r->scene.method);
    /* Warm starts need the state inside the lit VDB (.vdb) and a solver that keeps one. */
    r->sequence_warm =
        solver && solver->state && (!solver->state->sequence_on_request || r->options.keep_state) &&
        r->options.tolerance <= 0.0 && !r->options.warm_start &&
        !vdbs_options_flag(args, "--no-warm-start") && vdbs_options_has_extension(r->out, ".vdb");
    vdbs_sequence_step step = {0};
    step.command = "bake";
    step.worked = "baked";
    step.hash = frame_hash;
    step.run = frame_run;
    step.user = r;
    step.force = vdbs_options_flag(args, "--force");
    step.verify = vdbs_options_flag(args, "--verify");
    step.quiet = r->quiet;
    step.report_pattern = report;
    return vdbs_sequence_run(args, r->scene.volume_file, r->out, &step);
}

static int run(const vdbs_options_args *args)
{
    bake_request *r = malloc(sizeof *r); /* its scene alone is 32 KB */
    if (!r)
        return vdbs_command_fail("bake", 1, "out of memory");
    int status = prepare(args, r);
    if (status == VDBS_EXIT_OK && vdbs_sequence_requested(args, r->scene.volume_file, r->out)) {
        status = run_sequence(r);
    } else if (status == VDBS_EXIT_OK && (status = vdbs_sequence_refuse_flags(
                                              "bake", args, own_sequence_flags)) == VDBS_EXIT_OK) {
        /* One bake: its hash too, so that a sequence later finds it done. */
        frame_meta meta = {0};
        status = request_hash(r, r->scene.volume_file, 0.0, meta.hash);
        if (status == VDBS_EXIT_OK) {
            meta_add(&meta, VDBS_SEQUENCE_META_HASH, meta.hash);
            status = bake_one(r, &r->options, r->scene.volume_file, r->out, &meta, NULL);
        }
    }
    free(r);
    return status;
}

/* bake's options are its own, then every solver's flags from the solver table: filled once
 * (commands may run on several threads), after any solver the program registers before its
 * first command. */
const vdbs_command_spec *vdbs_command_bake(void)
{
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pthread_once(&once, fill_options);
    return &command;
}
