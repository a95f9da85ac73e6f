/* The flux-limited diffusion solver's entry (solver.h): its options, report block and run. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>

#include "vdbscatter/fld.h"
#include "vdbscatter/solver.h"

static const char *const on_off[] = {"on", "off", NULL};

#define FLD_MAX_RESOLUTION 1024

enum { OPT_RES, OPT_LIMITER, OPT_L1, OPT_P1 };

static const vdbs_solver_option options[] = {
    [OPT_RES] = {.key = "fld_res",
                 .flag = "--fld-res",
                 .syntax = "N",
                 .min = 2,
                 .max = FLD_MAX_RESOLUTION,
                 .help = "FLD: cells across the largest extent (default: 1/2/4/8\n"
                         "per transport free path per quality, at least\n"
                         "12/16/24/32, never finer than the voxels)"},
    [OPT_LIMITER] = {.key = "fld_limiter",
                     .flag = "--fld-limiter",
                     .kind = VDBS_OPTION_CHOICE,
                     .syntax = "on|off",
                     .choices = on_off,
                     .noun = "limiter",
                     .help = "FLD: Levermore-Pomraning flux limiter (default on) or\n"
                             "classic diffusion"},
    [OPT_L1] = {.key = "fld_l1",
                .flag = "--fld-l1",
                .kind = VDBS_OPTION_CHOICE,
                .syntax = "on|off",
                .choices = on_off,
                .help = "FLD: write ms_l1 from the diffusive flux (default on)"},
    [OPT_P1] = {.key = "fld_p1",
                .flag = "--fld-p1",
                .kind = VDBS_OPTION_CHOICE,
                .syntax = "on|off",
                .choices = on_off,
                .help = "FLD: the first-scattered light's first moment (P1 source;\n"
                        "default on) or an isotropic source"},
};

static int option_int(const vdbs_scene *scene, int i)
{
    return (int)vdbs_scene_solver_value(scene, options[i].key);
}

/* Exact S1 (with the unscattered light's flux for the first-moment source unless g = 0 or
 * --fld-p1 off), then flux-limited diffusion of the first-scattered light. */
static vdbs_status run_fld(const vdbs_solve *s, void *stats, vdbs_error *err)
{
    float *flux = NULL;
    if (s->scene->g != 0.0 && !option_int(s->scene, OPT_P1) && s->volume->coord_count > 0) {
        flux = malloc(sizeof *flux * 9 * s->volume->coord_count);
        if (!flux)
            return vdbs_error_set(err, VDBS_ERR_NOMEM,
                                  "out of memory for the S1 flux of %zu voxels",
                                  s->volume->coord_count);
    }
    vdbs_status st = vdbs_solve_s1(s, flux, NULL, NULL, err);
    if (st == VDBS_OK) {
        vdbs_fld_desc desc = {0};
        desc.resolution = option_int(s->scene, OPT_RES);
        desc.limiter_off = option_int(s->scene, OPT_LIMITER);
        desc.write_l1 = !option_int(s->scene, OPT_L1);
        desc.s1_flux = flux;
        st = vdbs_fld_solve(s, &desc, stats, err);
    }
    free(flux);
    return st;
}

static void report_json(const vdbs_scene *scene, const void *stats, cJSON *t, cJSON *fj)
{
    const vdbs_fld_stats *f = stats;
    cJSON_AddNumberToObject(t, "fld_source", f->seconds_source);
    cJSON_AddNumberToObject(t, "fld_solve", f->seconds_solve);
    cJSON_AddNumberToObject(t, "fld_upsample", f->seconds_upsample);
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
    cJSON_AddStringToObject(fj, "limiter", vdbs_solver_option_choice(scene, &options[OPT_LIMITER]));
    cJSON_AddStringToObject(fj, "l1", vdbs_solver_option_choice(scene, &options[OPT_L1]));
    cJSON_AddStringToObject(fj, "p1", vdbs_solver_option_choice(scene, &options[OPT_P1]));
}

static void report_text(const void *stats, char *text, size_t size)
{
    const vdbs_fld_stats *f = stats;
    snprintf(text, size, "%d cells across, %d CG iterations, residual %.2g", f->resolution,
             f->cg_iterations, f->residual);
}

const vdbs_solver vdbs_solver_fld = {
    .name = "fld",
    .summary = "exact single scattering + flux-limited diffusion of the first-scattered light",
    .writes_ms = 1,
    .options = options,
    .option_count = (int)(sizeof options / sizeof options[0]),
    .run = run_fld,
    .stats_size = sizeof(vdbs_fld_stats),
    .report_json = report_json,
    .report_text = report_text,
    .cost = {0},
};
