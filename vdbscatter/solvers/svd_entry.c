/* The discrete-ordinates solver's entry (solver.h): its options, report block, state
 * (--keep-state writes the radiance moments into the lit VDB, --warm-start reads them back)
 * and run. */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>

#include "vdbscatter/skyfloor.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/svd.h"

#define SVD_MAX_DIRECTIONS 16384 /* VDBS_PHASEMAT_MAX_DIRECTIONS */
#define SVD_MAX_RESOLUTION 512
#define SVD_MAX_ITERATIONS 100000

enum {
    OPT_DIRECTIONS,
    OPT_TERMS,
    OPT_RES,
    OPT_ACROSS,
    OPT_ITERATIONS,
    OPT_RESIDUAL,
    OPT_SCHEME,
    OPT_SKY
};

/* Index order: vdbs_svd_scheme's. */
static const char *const scheme_names[] = {"step", "diamond", NULL};

/* The presets are svd.h's lists, which vdbs_svd_quality reads too. */
static const vdbs_solver_option options[] = {
    [OPT_DIRECTIONS] = {.key = "svd_directions",
                        .flag = "--svd-directions",
                        .syntax = "D",
                        .min = 2,
                        .max = SVD_MAX_DIRECTIONS,
                        .help = "SVD: discrete directions (default 32/64/128/512 per quality)",
                        .preset = {VDBS_SVD_PRESET_DIRECTIONS}},
    [OPT_TERMS] = {.key = "svd_terms",
                   .flag = "--svd-terms",
                   .syntax = "N",
                   .min = 1,
                   .max = SVD_MAX_DIRECTIONS,
                   .help = "SVD: factored phase terms, N = D exact (default: the fewest\n"
                           "within 10/5/2/1% factorisation error per quality)"},
    [OPT_RES] = {.key = "svd_res",
                 .flag = "--svd-res",
                 .syntax = "N",
                 .min = 2,
                 .max = SVD_MAX_RESOLUTION,
                 .help = "SVD: cells across the largest extent (default 16/24/32/32)",
                 .preset = {VDBS_SVD_PRESET_RESOLUTION}},
    [OPT_ACROSS] = {.key = "svd_across",
                    .flag = "--svd-across",
                    .syntax = "N",
                    .min = 1,
                    .max = SVD_MAX_RESOLUTION,
                    .help = "SVD: cells at least across every axis, shorter cells along a\n"
                            "thin one (default 8/8/12/12; 1: cubic cells)",
                    .preset = {VDBS_SVD_PRESET_ACROSS}},
    [OPT_ITERATIONS] = {.key = "svd_iterations",
                        .flag = "--svd-iterations",
                        .syntax = "N",
                        .min = 1,
                        .max = SVD_MAX_ITERATIONS,
                        .help = "SVD: cap of source iterations (default 2000)",
                        .preset = {2000, 2000, 2000, 2000}},
    [OPT_RESIDUAL] = {.key = "svd_residual",
                      .flag = "--residual",
                      .kind = VDBS_OPTION_NUMBER,
                      .syntax = "R",
                      .min = 0,
                      .max = 1,
                      .help = "SVD: stop when the fluence's estimated relative error is at\n"
                              "most R, then extrapolate along the iteration's tail (default\n"
                              "3e-2/3e-2/1e-2/3e-3)",
                      .preset = {VDBS_SVD_PRESET_RESIDUAL}},
    [OPT_SCHEME] = {.key = "svd_scheme",
                    .flag = "--svd-scheme",
                    .kind = VDBS_OPTION_CHOICE,
                    .syntax = "S",
                    .choices = scheme_names,
                    .noun = "scheme",
                    .report_key = "scheme",
                    .help = "SVD: the sweep's cell scheme: step (default) or diamond\n"
                            "(weighted by each axis's optical depth: less numerical\n"
                            "diffusion; docs/methods/svd.md has where each wins)"},
    [OPT_SKY] = {.key = "svd_sky",
                 .flag = "--svd-sky",
                 .kind = VDBS_OPTION_CHOICE,
                 .syntax = "collisions|boundary",
                 .choices = vdbs_sky_floor_ways,
                 .report_key = "sky",
                 .help = "SVD: the whole sky enters as first collisions (default),\n"
                         "or its uniform part through the grid's boundary (exact in\n"
                         "the white furnace; docs/methods/svd.md has where each wins)"},
};

static double option(const vdbs_scene *scene, int i)
{
    return vdbs_scene_solver_value(scene, options[i].key);
}

/* ---- state: the radiance moments ---- */

/* The moments and the names and metadata the lit VDB stores them under. */
typedef struct svd_state {
    vdbs_svd_moments moments; /* first: the solver reads the state as its moments */
    char (*names)[24];        /* "svd_m0000" ... per term */
    char directions[16], terms[16], contraction[32];
} svd_state;

/* The state's grids: svd_m0000, svd_m0001, ... */
#define STATE_PREFIX "svd_m"

static void grid_name(int k, char *name, size_t size)
{
    snprintf(name, size, STATE_PREFIX "%04d", k);
}

static void *state_create(void)
{
    return calloc(1, sizeof(svd_state));
}

static void state_destroy(void *state)
{
    svd_state *s = state;
    if (!s)
        return;
    vdbs_svd_moments_free(&s->moments);
    free(s->names);
    free(s);
}

static vdbs_status state_read(const char *path, const vdbs_volume *volume, const vdbs_scene *scene,
                              void **out, vdbs_error *err)
{
    svd_state *s = state_create();
    if (!s)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the warm start");
    vdbs_svd_moments *m = &s->moments;
    vdbio_lit *lit = NULL;
    vdbs_status st = vdbio_lit_open_prefix(path, STATE_PREFIX, &lit, err);
    const char *dt = st == VDBS_OK ? vdbio_lit_meta(lit, "vdbscatter_svd_directions") : NULL;
    const char *nt = st == VDBS_OK ? vdbio_lit_meta(lit, "vdbscatter_svd_terms") : NULL;
    const char *gt = st == VDBS_OK ? vdbio_lit_meta(lit, "vdbscatter_g") : NULL;
    const char *ct = st == VDBS_OK ? vdbio_lit_meta(lit, "vdbscatter_svd_contraction") : NULL;
    int directions = dt ? atoi(dt) : 0, terms = nt ? atoi(nt) : 0;
    char name[32];
    grid_name(terms > 0 ? terms - 1 : 0, name, sizeof name);
    if (st == VDBS_OK && (directions < 2 || terms < 1 || terms > directions || !gt ||
                          !vdbio_lit_has_grid(lit, name)))
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "--warm-start %s: no discrete-ordinates state in it (bake it with "
                            "--method svd --keep-state)",
                            path);
    if (st == VDBS_OK)
        st = vdbs_svd_moments_alloc(m, directions, terms, strtod(gt, NULL), volume->coord_count,
                                    err);
    for (int k = 0; k < terms && st == VDBS_OK; ++k) {
        grid_name(k, name, sizeof name);
        st = vdbs_solve_state_vec3(lit, name, volume, m->voxels[k], err);
    }
    if (st == VDBS_OK && ct) /* older states have none: 0, unknown */
        m->contraction = strtod(ct, NULL);
    if (lit)
        vdbio_lit_close(lit);
    if (st == VDBS_OK)
        st = vdbs_svd_warm_check(m, (int)option(scene, OPT_DIRECTIONS),
                                 (int)option(scene, OPT_TERMS), scene->g, err);
    if (st != VDBS_OK) {
        state_destroy(s);
        return st;
    }
    *out = s;
    return VDBS_OK;
}

static int state_grids(const void *state, vdbio_vec3_grid *grids, int max)
{
    svd_state *s = (svd_state *)state; /* the names are made here, once */
    return vdbs_solver_state_grids(STATE_PREFIX, s->moments.terms, s->moments.voxels, &s->names,
                                   grids, max);
}

static int state_meta(const void *state, vdbio_meta *meta, int max)
{
    svd_state *s = (svd_state *)state;
    if (max < 3 || s->moments.terms == 0)
        return 0;
    snprintf(s->directions, sizeof s->directions, "%d", s->moments.directions);
    snprintf(s->terms, sizeof s->terms, "%d", s->moments.terms);
    snprintf(s->contraction, sizeof s->contraction, "%.17g", s->moments.contraction);
    meta[0] = (vdbio_meta){"vdbscatter_svd_directions", s->directions};
    meta[1] = (vdbio_meta){"vdbscatter_svd_terms", s->terms};
    meta[2] = (vdbio_meta){"vdbscatter_svd_contraction", s->contraction};
    return 3;
}

/* The solve's settings from the scene's options (0: the quality's). */
static vdbs_svd_desc desc_of(const vdbs_scene *scene)
{
    vdbs_svd_desc desc = {0};
    desc.directions = (int)option(scene, OPT_DIRECTIONS);
    desc.terms = (int)option(scene, OPT_TERMS);
    desc.resolution = (int)option(scene, OPT_RES);
    desc.across = (int)option(scene, OPT_ACROSS);
    desc.residual = option(scene, OPT_RESIDUAL);
    desc.scheme = (vdbs_svd_scheme)option(scene, OPT_SCHEME);
    desc.sky_boundary = (int)option(scene, OPT_SKY) == VDBS_SKY_BOUNDARY;
    desc.max_iterations = (int)option(scene, OPT_ITERATIONS);
    return desc;
}

/* One moment grid per term. */
static int state_arrays(const vdbs_scene *scene, const void *warm)
{
    vdbs_svd_desc desc = desc_of(scene);
    desc.warm = warm ? &((const svd_state *)warm)->moments : NULL;
    return vdbs_svd_kept_terms(&desc, scene->quality, scene->g);
}

static const vdbs_solver_state state = {
    .create = state_create,
    .read = state_read,
    .grids = state_grids,
    .meta = state_meta,
    .arrays = state_arrays,
    .destroy = state_destroy,
};

/* ---- run and report ---- */

/* Exact S1, then discrete ordinates with the factored phase on the first-scattered light,
 * which comes from the S1 pass's own light grids. */
static vdbs_status run_svd(const vdbs_solve *s, void *stats, vdbs_error *err)
{
    vdbs_svd_desc desc = desc_of(s->scene);
    desc.warm = s->warm ? &((const svd_state *)s->warm)->moments : NULL;
    desc.keep = s->keep ? &((svd_state *)s->keep)->moments : NULL;
    desc.progress = s->progress;
    vdbs_svd_run *run = NULL;
    vdbs_status st = vdbs_svd_begin(s, &desc, &run, err);
    if (st == VDBS_OK)
        st = vdbs_solve_s1(s, vdbs_svd_light_depth, run, err);
    if (st == VDBS_OK)
        st = vdbs_svd_finish(run, stats, err);
    vdbs_svd_end(run);
    return st;
}

static vdbs_status validate(const vdbs_scene *scene, const char *prefix, vdbs_error *err)
{
    const int d = (int)option(scene, OPT_DIRECTIONS), n = (int)option(scene, OPT_TERMS);
    if (d > 0 && n > d)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%ssolver.svd_terms: %d terms for %d directions (at most D)", prefix,
                              n, d);
    return VDBS_OK;
}

/* The report block, in the report's order (the stats' fields by offset). */
static const vdbs_report_field report[] = {
    {"source", VDBS_REPORT_SECONDS, offsetof(vdbs_svd_stats, seconds_source)},
    {"solve", VDBS_REPORT_SECONDS, offsetof(vdbs_svd_stats, seconds_solve)},
    {"upsample", VDBS_REPORT_SECONDS, offsetof(vdbs_svd_stats, seconds_upsample)},
    {"directions", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, directions)},
    {"terms", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, terms)},
    {"factor_rmse", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, factor_rmse)},
    {"delta_m_f", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, delta_m_f)},
    {"g_scaled", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, g_scaled)},
    {"resolution", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, resolution)},
    {"cells", VDBS_REPORT_INT64, offsetof(vdbs_svd_stats, cells)},
    {"cell_side", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, cell_side)},
    {"warm_start", VDBS_REPORT_BOOL, offsetof(vdbs_svd_stats, warm_start)},
    {"iterations", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, iterations)},
    {"residual", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, residual)},
    {"contraction", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, contraction)},
    {"predicted_iterations", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, predicted_iterations)},
    {"converged", VDBS_REPORT_BOOL, offsetof(vdbs_svd_stats, converged)},
    {"extrapolated", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, extrapolated)},
    {"steps_per_sweep", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, steps_per_sweep)},
    {"chunk", VDBS_REPORT_INT, offsetof(vdbs_svd_stats, chunk)},
    {"cell_direction_updates", VDBS_REPORT_INT64, offsetof(vdbs_svd_stats, cell_direction_updates)},
    {"first_power", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, first_power)},
    {"emitted", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, emitted)},
    {"collided", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, collided)},
    {"leaked", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, leaked)},
    {"balance", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, balance)},
    {"clamped", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, clamped)},
    {"clamped_fraction", VDBS_REPORT_DOUBLE, offsetof(vdbs_svd_stats, clamped_fraction)},
};

static void report_text(const void *stats, char *text, size_t size)
{
    const vdbs_svd_stats *v = stats;
    snprintf(text, size, "D %d, N %d, %d iterations, residual %.2g%s", v->directions, v->terms,
             v->iterations, v->residual, v->converged ? "" : " (not converged)");
}

static int64_t solve_bytes(const vdbs_scene *scene, size_t voxels)
{
    (void)scene;
    return vdbs_svd_voxel_bytes(voxels);
}

const vdbs_solver vdbs_solver_svd = {
    .name = "svd",
    .summary = "exact single scattering + discrete ordinates with the SVD-factored phase "
               "(Gong et al.)",
    .writes_ms = 1,
    .options = options,
    .option_count = (int)(sizeof options / sizeof options[0]),
    .run = run_svd,
    .stats_size = sizeof(vdbs_svd_stats),
    .validate = validate,
    .report = report,
    .report_count = (int)(sizeof report / sizeof report[0]),
    .report_text = report_text,
    .state = &state,
    .solve_bytes = solve_bytes,
    .cost = {24, 187, 492, 6.53e+03}, /* bench/cost.md */
    /* medium's 64 sky ordinates at high and ultra: 256 measured worse on both env-map scenes
     * and no better elsewhere, for 4x the light grids (docs/planner.md, "Ladders") */
    .sky_directions = {0, 0, 64, 64},
};
