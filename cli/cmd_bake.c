/* vdbscatter bake IN.vdb -o OUT.vdb: light a density volume and write a lit VDB. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "interrupt.h"
#include "options.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/solver.h"

static const char help[] =
    "usage: vdbscatter bake IN.vdb -o OUT.vdb [options]\n"
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
    "                           time on general volumes; the list below)\n"
    "  --camera PX,PY,PZ:TX,TY,TZ:FOV   the camera radiance_view is written toward\n"
    "  --quality Q              low (default) | medium | high | ultra (sky directions\n"
    "                           16/64/256/1024;\n"
    "                           POP sky ordinates 8/16/32/64, epsilon_L 1e-2 .. 1e-5,\n"
    "                           radial grids 8^3 .. 64^3)\n"
    "  --pop-res N              POP: cells across the largest extent of the volume\n"
    "                           (default 4: POP's bias grows as its cells shrink)\n"
    "  --pop-ordinates N        POP: propagation grids for the sky (importance-sampled)\n"
    "  --pop-radial N           POP: a point light's radial grid, N x N octahedral texels\n"
    "                           times N shells (even; default 8/16/32/64 per quality)\n"
    "  --pop-importance         POP: sample the sky ordinates from the sky times the\n"
    "                           camera's importance (needs --camera; the bake is then\n"
    "                           view-dependent; default off)\n"
    "  --pop-iterations N       POP: cap of each sun's or ordinate's iterations before the\n"
    "                           isotropic residuum (default: Eq. 10, at most max(64, 4 x res))\n"
    "  --pop-decay LAW          POP anisotropy decay: mean-cosine (default; a exp(-sigma_s t\n"
    "                           (1 - g)), exact first moment) or paper (a g^(sigma_s t))\n"
    "  --pop-tally T            POP fluence per cell crossing: chord (default; the lobe's\n"
    "                           mean chord, 2/3 of a cell for isotropic light) or cell (the\n"
    "                           paper's one cell side)\n"
    "  --fld-res N              FLD: cells across the largest extent (default: 1/2/4/8\n"
    "                           per transport free path per quality, at least\n"
    "                           12/16/24/32, never finer than the voxels)\n"
    "  --fld-limiter on|off     FLD: Levermore-Pomraning flux limiter (default on) or\n"
    "                           classic diffusion\n"
    "  --fld-l1 on|off          FLD: write ms_l1 from the diffusive flux (default on)\n"
    "  --fld-p1 on|off          FLD: the first-scattered light's first moment (P1 source;\n"
    "                           default on) or an isotropic source\n"
    "  --svd-directions D       SVD: discrete directions (default 32/64/128/512 per quality)\n"
    "  --svd-terms N            SVD: factored phase terms, N = D exact (default: the fewest\n"
    "                           within 10/5/2/1% factorisation error per quality)\n"
    "  --svd-res N              SVD: cells across the largest extent (default 16/24/32/32)\n"
    "  --residual R             SVD: stop when the fluence changes by at most R per\n"
    "                           iteration (default 1e-2/3e-3/1e-3/3e-4)\n"
    "  --svd-iterations N       SVD: cap of source iterations (default 2000)\n"
    "  --keep-state             SVD: also write the N radiance moment grids svd_m0000...\n"
    "  --warm-start FILE.vdb    SVD: start from a --keep-state bake's moments (its D and N)\n"
    "\n"
    "other options:\n"
    "  -o, --output FILE        lit VDB to write (refused if equal to the input)\n"
    "  --backend auto|cpu|gpu   auto: a hardware GPU if EGL finds one, else the C "
    "path\n" CLI_S1_HELP
    "  --from-levelset          convert a level set to a fog volume instead of refusing it\n"
    "  --half                   store grids as half floats (values clamped to 65504)\n"
    "  --report FILE.json       write timings per stage, parameters and output grids\n"
    "  --json                   print the report as JSON on stdout\n"
    "  -q                       no progress, summary or warnings\n";

static const cli_option options[] = {
    CLI_COMMON_OPTIONS,
    {"--from-levelset", CLI_FLAG},
    {"--half", CLI_FLAG},
    {"--report", CLI_VALUE},
    {"--method", CLI_VALUE},
    {"--pop-res", CLI_VALUE},
    {"--pop-ordinates", CLI_VALUE},
    {"--pop-decay", CLI_VALUE},
    {"--pop-iterations", CLI_VALUE},
    {"--pop-tally", CLI_VALUE},
    {"--pop-radial", CLI_VALUE},
    {"--pop-importance", CLI_FLAG},
    {"--fld-res", CLI_VALUE},
    {"--fld-limiter", CLI_VALUE},
    {"--fld-l1", CLI_VALUE},
    {"--fld-p1", CLI_VALUE},
    {"--svd-directions", CLI_VALUE},
    {"--svd-terms", CLI_VALUE},
    {"--svd-res", CLI_VALUE},
    {"--residual", CLI_VALUE},
    {"--svd-iterations", CLI_VALUE},
    {"--keep-state", CLI_FLAG},
    {"--warm-start", CLI_VALUE},
    {"--camera", CLI_VALUE},
    {NULL, CLI_FLAG},
};

static cJSON *report_json(const char *input, const char *output, const vdbs_scene *scene,
                          const vdbs_bake_report *r)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "input", input);
    cJSON_AddStringToObject(j, "output", output);
    cJSON_AddStringToObject(j, "grid", r->grid);
    cJSON_AddStringToObject(j, "method", scene->method);
    cJSON_AddStringToObject(j, "quality", scene->quality);
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
        cli_json_light_grids(j, &r->s1_grids);
    }
    if (strcmp(scene->method, "pop") == 0) {
        const vdbs_pop_stats *p = &r->pop;
        cJSON_AddNumberToObject(t, "pop_sweep", p->seconds_sweep);
        cJSON_AddNumberToObject(t, "pop_seed", p->seconds_seed);
        cJSON_AddNumberToObject(t, "pop_propagate", p->seconds_propagate);
        cJSON_AddNumberToObject(t, "pop_isotropic", p->seconds_isotropic);
        cJSON_AddNumberToObject(t, "pop_merge", p->seconds_merge);
        cJSON_AddNumberToObject(t, "pop_upsample", p->seconds_upsample);
        cJSON_AddNumberToObject(t, "pop_importance", p->seconds_importance);
        cJSON *pj = cJSON_AddObjectToObject(j, "pop");
        cJSON_AddNumberToObject(pj, "grids", p->grids);
        cJSON_AddNumberToObject(pj, "radial_grids", p->radial_grids);
        cJSON_AddNumberToObject(pj, "radial", p->radial);
        cJSON_AddStringToObject(pj, "importance", p->importance ? "on" : "off");
        cJSON_AddNumberToObject(pj, "importance_cells", (double)p->importance_cells);
        cJSON_AddNumberToObject(pj, "importance_iterations", p->importance_iterations);
        cJSON_AddNumberToObject(pj, "resolution", p->resolution);
        cJSON_AddNumberToObject(pj, "cells", (double)p->cells);
        cJSON_AddNumberToObject(pj, "merged_cells", (double)p->merged_cells);
        cJSON_AddNumberToObject(pj, "iterations_anisotropic", p->iterations_anisotropic);
        cJSON_AddNumberToObject(pj, "iterations_isotropic", p->iterations_isotropic);
        cJSON_AddNumberToObject(pj, "cell_updates", p->cell_updates);
        cJSON_AddNumberToObject(pj, "cell_side", p->cell_side);
        cJSON_AddNumberToObject(pj, "seeded", p->seeded);
        cJSON_AddNumberToObject(pj, "beam_loss", p->beam_loss);
        cJSON_AddNumberToObject(pj, "residual", p->residual);
        cJSON_AddNumberToObject(pj, "merge_in", p->merge_in);
        cJSON_AddNumberToObject(pj, "merge_out", p->merge_out);
        cJSON_AddStringToObject(pj, "decay", scene->pop_decay_paper ? "paper" : "mean-cosine");
        cJSON_AddStringToObject(pj, "tally", scene->pop_tally_cell ? "cell" : "chord");
    }
    if (strcmp(scene->method, "fld") == 0) {
        const vdbs_fld_stats *f = &r->fld;
        cJSON_AddNumberToObject(t, "fld_source", f->seconds_source);
        cJSON_AddNumberToObject(t, "fld_solve", f->seconds_solve);
        cJSON_AddNumberToObject(t, "fld_upsample", f->seconds_upsample);
        cJSON *fj = cJSON_AddObjectToObject(j, "fld");
        cJSON_AddNumberToObject(fj, "resolution", f->resolution);
        cJSON_AddNumberToObject(fj, "mean_sigma_tr", f->mean_sigma_tr);
        cJSON_AddNumberToObject(fj, "cells", (double)f->cells);
        cJSON_AddNumberToObject(fj, "cell_side", f->cell_side);
        cJSON_AddNumberToObject(fj, "updates", f->updates);
        cJSON_AddNumberToObject(fj, "cg_iterations", f->cg_iterations);
        cJSON_AddNumberToObject(fj, "levels", f->levels);
        cJSON_AddNumberToObject(fj, "operator_applications", f->operator_applications);
        cJSON_AddNumberToObject(fj, "cell_updates", (double)f->cell_updates);
        cJSON_AddNumberToObject(fj, "residual", f->residual);
        cJSON_AddNumberToObject(fj, "source", f->source);
        cJSON_AddNumberToObject(fj, "absorbed", f->absorbed);
        cJSON_AddNumberToObject(fj, "leaked", f->leaked);
        cJSON_AddStringToObject(fj, "limiter", scene->fld_limiter_off ? "off" : "on");
        cJSON_AddStringToObject(fj, "l1", scene->fld_l1_off ? "off" : "on");
        cJSON_AddStringToObject(fj, "p1", scene->fld_p1_off ? "off" : "on");
    }
    if (strcmp(scene->method, "svd") == 0) {
        const vdbs_svd_stats *v = &r->svd;
        cJSON_AddNumberToObject(t, "svd_source", v->seconds_source);
        cJSON_AddNumberToObject(t, "svd_solve", v->seconds_solve);
        cJSON_AddNumberToObject(t, "svd_upsample", v->seconds_upsample);
        cJSON *sj = cJSON_AddObjectToObject(j, "svd");
        cJSON_AddNumberToObject(sj, "directions", v->directions);
        cJSON_AddNumberToObject(sj, "terms", v->terms);
        cJSON_AddNumberToObject(sj, "factor_rmse", v->factor_rmse);
        cJSON_AddNumberToObject(sj, "delta_m_f", v->delta_m_f);
        cJSON_AddNumberToObject(sj, "g_scaled", v->g_scaled);
        cJSON_AddNumberToObject(sj, "resolution", v->resolution);
        cJSON_AddNumberToObject(sj, "cells", (double)v->cells);
        cJSON_AddNumberToObject(sj, "cell_side", v->cell_side);
        cJSON_AddNumberToObject(sj, "iterations", v->iterations);
        cJSON_AddNumberToObject(sj, "residual", v->residual);
        cJSON_AddBoolToObject(sj, "converged", v->converged);
        cJSON_AddNumberToObject(sj, "steps_per_sweep", v->steps_per_sweep);
        cJSON_AddNumberToObject(sj, "chunk", v->chunk);
        cJSON_AddNumberToObject(sj, "cell_direction_updates", (double)v->cell_direction_updates);
        cJSON_AddNumberToObject(sj, "first_power", v->first_power);
        cJSON_AddNumberToObject(sj, "emitted", v->emitted);
        cJSON_AddNumberToObject(sj, "collided", v->collided);
        cJSON_AddNumberToObject(sj, "leaked", v->leaked);
        cJSON_AddNumberToObject(sj, "balance", v->balance);
        cJSON_AddNumberToObject(sj, "clamped", v->clamped);
        cJSON_AddNumberToObject(sj, "clamped_fraction", v->clamped_fraction);
    }
    double rmax[3] = {r->radiance_max[0], r->radiance_max[1], r->radiance_max[2]};
    cJSON_AddItemToObject(j, "radiance_max", cli_json_triple(rmax));
    const char *grids[] = {"density", "radiance", "ms",           "ms_l1x",
                           "ms_l1y",  "ms_l1z",   "radiance_view"};
    cJSON_AddItemToObject(j, "grids",
                          cJSON_CreateStringArray(grids, scene->camera.present ? 7 : 6));
    char *scene_text = vdbs_scene_to_json(scene);
    cJSON *parsed = scene_text ? cJSON_Parse(scene_text) : NULL;
    free(scene_text);
    if (parsed)
        cJSON_AddItemToObject(j, "scene", parsed);
    return j;
}

/* The solver table, so that --help lists exactly what --method accepts. */
static void print_methods(void)
{
    int count = 0;
    const vdbs_solver *solvers = vdbs_solver_list(&count);
    fputs("\nmethods (--method):\n", stdout);
    for (int m = 0; m < count; ++m)
        printf("  %-24s %s\n", solvers[m].name, solvers[m].summary);
}

int cmd_bake(int argc, char **argv)
{
    cli_args args;
    vdbs_error err;
    vdbs_status st;
    if (cli_parse(argc, argv, options, &args, &err) != VDBS_OK)
        return cli_fail("bake", 2, err.message);
    if (args.help) {
        fputs(help, stdout);
        print_methods();
        return CLI_EXIT_OK;
    }
    if (args.positional_count > 1)
        return cli_fail("bake", 2, "expected one input VDB");
    const char *out = cli_output(&args);
    if (!out)
        return cli_fail("bake", 2, "missing -o OUT.vdb");
    vdbs_scene scene;
    struct stat out_stat;
    int out_is_dir = stat(out, &out_stat) == 0 && S_ISDIR(out_stat.st_mode);
    if (!out_is_dir && !cli_has_extension(out, ".vdb")) /* a folder: the write says so */
        return cli_fail("bake", 2,
                        "-o: a lit VDB is written as OpenVDB: give a name ending in .vdb");
    /* Lights are checked after the input file and grid (vdbs_bake), so that a missing file is
     * not reported as a missing light. */
    if ((st = cli_build_scene(&args, &scene, 1, &err)) != VDBS_OK)
        return cli_fail("bake", st, err.message);
    if ((st = cli_scene_occluders("bake", &args, &scene, cli_flag(&args, "-q"), &err)) != VDBS_OK)
        return cli_fail("bake", st, err.message);
    const char *camera = cli_value(&args, "--camera");
    if (camera) {
        vdbs_camera c;
        if ((st = cli_camera(camera, &c, &err)) != VDBS_OK)
            return cli_fail("bake", st, err.message);
        /* The render of the lit VDB frames with it: keep the scene's size, else the render's
         * default. */
        c.width = scene.camera.present ? scene.camera.width : 640;
        c.height = scene.camera.present ? scene.camera.height : 480;
        scene.camera = c;
    }
    const char *input = args.positional_count ? args.positional[0] : scene.volume_file;
    if (!input[0])
        return cli_fail("bake", 2, "no input VDB (give IN.vdb or volume.file in --scene)");
    vdbs_bake_options o = {0};
    o.input = input;
    o.output = out;
    o.scene = &scene;
    const char *backend = cli_value(&args, "--backend");
    if (backend && (st = vdbs_backend_parse(backend, &o.backend, &err)) != VDBS_OK)
        return cli_fail("bake", st, err.message);
    int quiet = cli_flag(&args, "-q");
    if ((st = cli_s1_options(&args, &o.s1_march, &o.s1_oversample, &err)) != VDBS_OK)
        return cli_fail("bake", st, err.message);
    o.from_levelset = cli_flag(&args, "--from-levelset");
    o.half = cli_flag(&args, "--half");
    o.keep_state = cli_flag(&args, "--keep-state");
    o.warm_start = cli_value(&args, "--warm-start");
    o.progress = !quiet && isatty(STDERR_FILENO);
    o.warn = cli_warn;
    o.warn_user = &quiet;
    o.cancel = cli_interrupt_install();

    vdbs_bake_report report;
    if ((st = vdbs_bake(&o, &report, &err)) != VDBS_OK)
        return st == VDBS_ERR_CANCELLED ? cli_interrupt_status("bake", CLI_EXIT_FAILURE)
                                        : cli_fail("bake", st, err.message);

    double target_depth = scene.density_target_depth;
    scene.density_scale = report.density_scale; /* as resolved (auto:TAU) */
    scene.density_target_depth = 0.0;
    cJSON *j = report_json(input, out, &scene, &report);
    cJSON_AddNumberToObject(j, "density_scale", report.density_scale);
    if (target_depth > 0.0)
        cJSON_AddNumberToObject(j, "density_target_depth", target_depth);
    cJSON_AddNumberToObject(j, "mean_optical_depth", report.advice.mean_depth);
    cJSON_AddNumberToObject(j, "ms_to_ss_estimate", report.advice.ms_to_ss);
    const char *report_path = cli_value(&args, "--report");
    int status = CLI_EXIT_OK;
    if (report_path) {
        char *text = cJSON_Print(j);
        FILE *f = fopen(report_path, "w");
        if (!f || fputs(text, f) < 0 || fputc('\n', f) < 0)
            status = cli_fail("bake", 1, "cannot write the --report file");
        if (f && fclose(f) != 0)
            status = cli_fail("bake", 1, "cannot write the --report file");
        free(text);
    }
    if (cli_flag(&args, "--json")) {
        char *text = cJSON_Print(j);
        puts(text);
        free(text);
    } else if (!quiet) {
        fprintf(stderr,
                "baked %llu voxels of '%s' (%s, quality %s) on %s in %.2fs (solve %.2fs) -> %s\n",
                report.output_voxels, report.grid, scene.method, scene.quality, report.backend,
                report.seconds_total, report.seconds_solve, out);
    }
    cJSON_Delete(j);
    return cli_interrupt_status("bake", status); /* a signal after the new file was in place */
}
