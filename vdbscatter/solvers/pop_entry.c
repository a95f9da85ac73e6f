/* The POP solver's entry (solver.h): its options, report block and run. */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "vdbscatter/pop.h"
#include "vdbscatter/solver.h"

static const char *const decay_names[] = {"mean-cosine", "paper", NULL};
static const char *const tally_names[] = {"chord", "cell", NULL};
static const char *const off_on[] = {"off", "on", NULL};

/* Most cells across the largest extent, texels of a radial grid, iterations of a grid. */
#define POP_MAX_RESOLUTION 512
#define POP_MAX_RADIAL 256
#define POP_MAX_ITERATIONS 100000

enum { OPT_RES, OPT_ORDINATES, OPT_ITERATIONS, OPT_DECAY, OPT_TALLY, OPT_RADIAL, OPT_IMPORTANCE };

/* The order is the scene file's and the help's. The presets are pop.c's (test_pop checks). */
static const vdbs_solver_option options[] = {
    [OPT_RES] = {.key = "pop_res",
                 .flag = "--pop-res",
                 .syntax = "N",
                 .min = 2,
                 .max = POP_MAX_RESOLUTION,
                 .help = "POP: cells across the largest extent of the volume\n"
                         "(default 4: POP's bias grows as its cells shrink)",
                 .preset = {4, 4, 4, 4}},
    [OPT_ORDINATES] = {.key = "pop_ordinates",
                       .flag = "--pop-ordinates",
                       .syntax = "N",
                       .min = 1,
                       .max = VDBS_MAX_SKY_DIRECTIONS,
                       .help = "POP: propagation grids for the sky (importance-sampled;\n"
                               "default 8 at every quality: more measured worse)",
                       .preset = {8, 8, 8, 8}},
    [OPT_ITERATIONS] = {.key = "pop_iterations",
                        .flag = "--pop-iterations",
                        .syntax = "N",
                        .min = 1,
                        .max = POP_MAX_ITERATIONS,
                        .help = "POP: cap of each sun's or ordinate's iterations before the\n"
                                "isotropic residuum (default: Eq. 10, at most max(64, 4 x res))"},
    [OPT_DECAY] = {.key = "pop_decay",
                   .flag = "--pop-decay",
                   .kind = VDBS_OPTION_CHOICE,
                   .syntax = "LAW",
                   .choices = decay_names,
                   .noun = "decay",
                   .report_key = "decay",
                   .help = "POP anisotropy decay: mean-cosine (default; a exp(-sigma_s t\n"
                           "(1 - g)), exact first moment) or paper (a g^(sigma_s t))"},
    [OPT_TALLY] = {.key = "pop_tally",
                   .flag = "--pop-tally",
                   .kind = VDBS_OPTION_CHOICE,
                   .syntax = "T",
                   .choices = tally_names,
                   .noun = "tally",
                   .report_key = "tally",
                   .help = "POP fluence per cell crossing: chord (default; the lobe's\n"
                           "mean chord, 2/3 of a cell for isotropic light) or cell (the\n"
                           "paper's one cell side)"},
    [OPT_RADIAL] = {.key = "pop_radial",
                    .flag = "--pop-radial",
                    .syntax = "N",
                    .min = 2,
                    .max = POP_MAX_RADIAL,
                    .even = "the octahedral map",
                    .help = "POP: a point light's radial grid, N x N octahedral texels\n"
                            "times N shells (even; default 8 at every quality: finer\n"
                            "grids helped lights outside the medium, hurt lights inside)",
                    .preset = {8, 16, 32, 64}},
    [OPT_IMPORTANCE] = {.key = "pop_importance",
                        .flag = "--pop-importance",
                        .kind = VDBS_OPTION_CHOICE,
                        .choices = off_on,
                        .help = "POP: sample the sky ordinates from the sky times the\n"
                                "camera's importance (needs --camera; the bake is then\n"
                                "view-dependent; default off)"},
};

static int option_int(const vdbs_scene *scene, int i)
{
    return (int)vdbs_scene_solver_value(scene, options[i].key);
}

/* Exact S1, then POP's multiple scattering from suns, skies and points. */
/* The solve's desc from the scene's options (0: the quality's defaults). */
static void desc_of(const vdbs_scene *scene, vdbs_pop_desc *desc)
{
    memset(desc, 0, sizeof *desc);
    desc->resolution = option_int(scene, OPT_RES);
    desc->ordinates = option_int(scene, OPT_ORDINATES);
    desc->max_iterations = option_int(scene, OPT_ITERATIONS);
    desc->decay = option_int(scene, OPT_DECAY) ? VDBS_POP_DECAY_PAPER : VDBS_POP_DECAY_MEAN_COSINE;
    desc->tally_cell = option_int(scene, OPT_TALLY);
    desc->radial = option_int(scene, OPT_RADIAL);
    desc->importance = option_int(scene, OPT_IMPORTANCE);
}

static vdbs_status check(const vdbs_scene *scene, vdbs_error *err)
{
    vdbs_pop_desc desc;
    desc_of(scene, &desc);
    return vdbs_pop_check(&desc, scene, err);
}

static vdbs_status run_pop(const vdbs_solve *s, void *stats, vdbs_error *err)
{
    vdbs_status st = vdbs_solve_s1(s, NULL, NULL, err);
    if (st != VDBS_OK)
        return st;
    vdbs_pop_desc desc;
    desc_of(s->scene, &desc);
    return vdbs_pop_solve(s, &desc, stats, err);
}

/* The report block, in the report's order (the stats' fields by offset). */
static const vdbs_report_field report[] = {
    {"sweep", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_sweep)},
    {"seed", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_seed)},
    {"propagate", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_propagate)},
    {"isotropic", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_isotropic)},
    {"merge", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_merge)},
    {"upsample", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_upsample)},
    {"importance", VDBS_REPORT_SECONDS, offsetof(vdbs_pop_stats, seconds_importance)},
    {"grids", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, grids)},
    {"radial_grids", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, radial_grids)},
    {"radial", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, radial)},
    {"importance", VDBS_REPORT_ON_OFF, offsetof(vdbs_pop_stats, importance)},
    {"importance_cells", VDBS_REPORT_INT64, offsetof(vdbs_pop_stats, importance_cells)},
    {"importance_iterations", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, importance_iterations)},
    {"resolution", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, resolution)},
    {"cells", VDBS_REPORT_INT64, offsetof(vdbs_pop_stats, cells)},
    {"merged_cells", VDBS_REPORT_INT64, offsetof(vdbs_pop_stats, merged_cells)},
    {"iterations_anisotropic", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, iterations_anisotropic)},
    {"iterations_isotropic", VDBS_REPORT_INT, offsetof(vdbs_pop_stats, iterations_isotropic)},
    {"cell_updates", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, cell_updates)},
    {"cell_side", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, cell_side)},
    {"seeded", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, seeded)},
    {"beam_loss", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, beam_loss)},
    {"residual", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, residual)},
    {"merge_in", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, merge_in)},
    {"merge_out", VDBS_REPORT_DOUBLE, offsetof(vdbs_pop_stats, merge_out)},
};

static void report_text(const void *stats, char *text, size_t size)
{
    const vdbs_pop_stats *p = stats;
    snprintf(text, size, "%d grids + %d radial, %d cells across, residual %.2g", p->grids,
             p->radial_grids, p->resolution, p->residual);
}

const vdbs_solver vdbs_solver_pop = {
    .name = "pop",
    .summary = "exact single scattering + Principal-Ordinates Propagation (suns, skies, points)",
    .writes_ms = 1,
    .options = options,
    .option_count = (int)(sizeof options / sizeof options[0]),
    .run = run_pop,
    .check = check,
    .stats_size = sizeof(vdbs_pop_stats),
    .report = report,
    .report_count = (int)(sizeof report / sizeof report[0]),
    .report_text = report_text,
    /* bench/cost.md at low: every quality bakes as low (ladder_stop) */
    .cost = {9.39, 9.39, 9.39, 9.39},
    /* 16 at every quality: a finer sky raised POP's error (docs/planner.md, "Ladders") */
    .sky_directions = {16, 16, 16, 16},
    /* A point light's finer radial grids moved the error both ways on the calibration set
     * (better on the sphere's light outside and the smoke's at its edge, worse on the lights
     * inside the USD smoke, the box and the plasma);
     * suns and skies gained nothing past low (docs/planner.md, "Ladders"). */
    .ladder_stop = "low",
};
