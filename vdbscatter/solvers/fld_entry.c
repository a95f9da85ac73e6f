/* The flux-limited diffusion solver's entry (solver.h): its options, report block, state
 * (--keep-state writes the solved fluence phi into the lit VDB, --warm-start reads it back)
 * and run. */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/collision.h"
#include "vdbscatter/fld.h"
#include "vdbscatter/skyfloor.h"
#include "vdbscatter/solver.h"

static const char *const on_off[] = {"on", "off", NULL};

#define FLD_MAX_RESOLUTION 1024

enum { OPT_RES, OPT_ACROSS, OPT_LIMITER, OPT_L1, OPT_P1, OPT_SKY };

static const vdbs_solver_option options[] = {
    [OPT_RES] = {.key = "fld_res",
                 .flag = "--fld-res",
                 .syntax = "N",
                 .min = 2,
                 .max = FLD_MAX_RESOLUTION,
                 .help = "FLD: cells across the largest extent (default: one per\n"
                         "transport free path at every quality, at least 12, never\n"
                         "finer than the voxels: finer grids measured worse)"},
    [OPT_ACROSS] = {.key = "fld_across",
                    .flag = "--fld-across",
                    .syntax = "N",
                    .min = 1,
                    .max = FLD_MAX_RESOLUTION,
                    .help = "FLD: cells at least across every axis, shorter cells along a\n"
                            "thin one (default 8; 1: cubic cells)"},
    [OPT_LIMITER] = {.key = "fld_limiter",
                     .flag = "--fld-limiter",
                     .kind = VDBS_OPTION_CHOICE,
                     .syntax = "on|off",
                     .choices = on_off,
                     .noun = "limiter",
                     .report_key = "limiter",
                     .help = "FLD: Levermore-Pomraning flux limiter (default on) or\n"
                             "classic diffusion"},
    [OPT_L1] = {.key = "fld_l1",
                .flag = "--fld-l1",
                .kind = VDBS_OPTION_CHOICE,
                .syntax = "on|off",
                .choices = on_off,
                .report_key = "l1",
                .help = "FLD: write ms_l1 from the diffusive flux (default on)"},
    [OPT_P1] = {.key = "fld_p1",
                .flag = "--fld-p1",
                .kind = VDBS_OPTION_CHOICE,
                .syntax = "on|off",
                .choices = on_off,
                .report_key = "p1",
                .help = "FLD: the first-scattered light's first moment (P1 source;\n"
                        "default on) or an isotropic source"},
    [OPT_SKY] = {.key = "fld_sky",
                 .flag = "--fld-sky",
                 .kind = VDBS_OPTION_CHOICE,
                 .syntax = "collisions|boundary",
                 .choices = vdbs_sky_floor_ways,
                 .report_key = "sky",
                 .help = "FLD: the whole sky enters as first collisions (default),\n"
                         "or its uniform part through the grid's boundary (exact in\n"
                         "the white furnace; docs/methods/fld.md has where each wins)"},
};

static int option_int(const vdbs_scene *scene, int i)
{
    return (int)vdbs_scene_solver_value(scene, options[i].key);
}

/* ---- state: the fluence phi ---- */

#define FLD_STATE_GRID "fld_phi"
#define FLD_STATE_KEY "vdbscatter_fld_state"
#define FLD_STATE_VALUE "phi"

static void *state_create(void)
{
    return calloc(1, sizeof(vdbs_fld_state));
}

static void state_destroy(void *state)
{
    vdbs_fld_state *s = state;
    if (!s)
        return;
    free(s->phi);
    free(s);
}

static vdbs_status state_read(const char *path, const vdbs_volume *volume, const vdbs_scene *scene,
                              void **out, vdbs_error *err)
{
    (void)scene; /* phi is a first guess: any medium or options converge from it */
    vdbs_fld_state *s = state_create();
    if (!s)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the warm start");
    vdbio_lit *lit = NULL;
    vdbs_status st = vdbio_lit_open_prefix(path, FLD_STATE_GRID, &lit, err);
    const char *kind = st == VDBS_OK ? vdbio_lit_meta(lit, FLD_STATE_KEY) : NULL;
    if (st == VDBS_OK &&
        (!kind || strcmp(kind, FLD_STATE_VALUE) != 0 || !vdbio_lit_has_grid(lit, FLD_STATE_GRID)))
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "--warm-start %s: no flux-limited diffusion state in it (bake it with "
                            "--method fld --keep-state)",
                            path);
    if (st == VDBS_OK) {
        s->voxels = volume->coord_count;
        s->phi = malloc(sizeof *s->phi * 3 * (s->voxels ? s->voxels : 1));
        if (!s->phi)
            st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the warm start");
    }
    if (st == VDBS_OK)
        st = vdbs_solve_state_vec3(lit, FLD_STATE_GRID, volume, s->phi, err);
    if (lit)
        vdbio_lit_close(lit);
    if (st != VDBS_OK) {
        state_destroy(s);
        return st;
    }
    *out = s;
    return VDBS_OK;
}

static int state_grids(const void *state, vdbio_vec3_grid *grids, int max)
{
    const vdbs_fld_state *s = state;
    if (!s->phi)
        return 0; /* not solved (yet) */
    if (!grids)
        return 1;
    if (max < 1)
        return 0;
    grids[0] = (vdbio_vec3_grid){FLD_STATE_GRID, s->phi};
    return 1;
}

static int state_meta(const void *state, vdbio_meta *meta, int max)
{
    const vdbs_fld_state *s = state;
    if (max < 1 || !s->phi)
        return 0;
    meta[0] = (vdbio_meta){FLD_STATE_KEY, FLD_STATE_VALUE};
    return 1;
}

/* The fluence phi. */
static int state_arrays(const vdbs_scene *scene, const void *warm)
{
    (void)scene;
    (void)warm;
    return 1;
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

/* The S1 pass's per-light callback: every light's first collisions, a sky ordinate's less
 * the sky's uniform part, which enters through the boundary (skyfloor.h). */
typedef struct fld_first {
    vdbs_collision_sum sum;
    vdbs_sky_floor floor;
} fld_first;

static void fld_first_light(void *user, int light, const float *depth)
{
    fld_first *x = user;
    const vdbs_light_table *lights = x->sum.lights;
    if (light < lights->direct_count || !vdbs_sky_floor_active(&x->floor)) {
        vdbs_collision_sum_light(&x->sum, light, depth);
        return;
    }
    double rest[3];
    vdbs_sky_floor_light(&x->floor, x->sum.volume, lights, light, depth, rest);
    vdbs_collision_sum_share(&x->sum, light, depth, rest);
}

/* Whether the first collisions carry their flux for the first-moment source: unless g = 0
 * or --fld-p1 off. */
static int with_p1(const vdbs_scene *scene)
{
    return scene->g != 0.0 && !option_int(scene, OPT_P1);
}

/* Exact S1, every light's first collisions (with their flux, with_p1), then flux-limited
 * diffusion of the first-scattered light; with --fld-sky boundary the sky's uniform part
 * enters through the grid's boundary. */
static vdbs_status run_fld(const vdbs_solve *s, void *stats, vdbs_error *err)
{
    const int p1 = with_p1(s->scene);
    fld_first first;
    memset(&first, 0, sizeof first);
    vdbs_status st =
        vdbs_collision_sum_init(&first.sum, s->volume, s->lights, s->scene->density_scale, p1, err);
    if (st == VDBS_OK && option_int(s->scene, OPT_SKY) == VDBS_SKY_BOUNDARY)
        st = vdbs_sky_floor_init(&first.floor, s->volume, s->lights, err);
    if (st == VDBS_OK)
        st = vdbs_solve_s1(s, fld_first_light, &first, err);
    if (st == VDBS_OK) {
        vdbs_fld_desc desc = {0};
        desc.resolution = option_int(s->scene, OPT_RES);
        desc.across = option_int(s->scene, OPT_ACROSS);
        desc.limiter_off = option_int(s->scene, OPT_LIMITER);
        desc.write_l1 = !option_int(s->scene, OPT_L1);
        desc.collisions = first.sum.total;
        desc.collision_flux = first.sum.flux;
        desc.sky_floor = vdbs_sky_floor_active(&first.floor) ? &first.floor : NULL;
        desc.warm = s->warm;
        desc.keep = s->keep;
        st = vdbs_fld_solve(s, &desc, stats, err);
    }
    vdbs_collision_sum_free(&first.sum);
    vdbs_sky_floor_free(&first.floor);
    return st;
}

/* The report block, in the report's order (the stats' fields by offset). */
static const vdbs_report_field report[] = {
    {"source", VDBS_REPORT_SECONDS, offsetof(vdbs_fld_stats, seconds_source)},
    {"solve", VDBS_REPORT_SECONDS, offsetof(vdbs_fld_stats, seconds_solve)},
    {"upsample", VDBS_REPORT_SECONDS, offsetof(vdbs_fld_stats, seconds_upsample)},
    {"resolution", VDBS_REPORT_INT, offsetof(vdbs_fld_stats, resolution)},
    {"mean_sigma_tr", VDBS_REPORT_DOUBLE, offsetof(vdbs_fld_stats, mean_sigma_tr)},
    {"cells", VDBS_REPORT_INT64, offsetof(vdbs_fld_stats, cells)},
    {"cell_side", VDBS_REPORT_DOUBLE, offsetof(vdbs_fld_stats, cell_side)},
    {"warm_start", VDBS_REPORT_BOOL, offsetof(vdbs_fld_stats, warm_start)},
    {"updates", VDBS_REPORT_INT, offsetof(vdbs_fld_stats, updates)},
    {"cg_iterations", VDBS_REPORT_INT, offsetof(vdbs_fld_stats, cg_iterations)},
    {"levels", VDBS_REPORT_INT, offsetof(vdbs_fld_stats, levels)},
    {"operator_applications", VDBS_REPORT_INT, offsetof(vdbs_fld_stats, operator_applications)},
    {"cell_updates", VDBS_REPORT_INT64, offsetof(vdbs_fld_stats, cell_updates)},
    {"residual", VDBS_REPORT_DOUBLE, offsetof(vdbs_fld_stats, residual)},
    {"source", VDBS_REPORT_DOUBLE, offsetof(vdbs_fld_stats, source)},
    {"absorbed", VDBS_REPORT_DOUBLE, offsetof(vdbs_fld_stats, absorbed)},
    {"leaked", VDBS_REPORT_DOUBLE, offsetof(vdbs_fld_stats, leaked)},
};

static void report_text(const void *stats, char *text, size_t size)
{
    const vdbs_fld_stats *f = stats;
    snprintf(text, size, "%d cells across, %d CG iterations in %d solves%s, residual %.2g",
             f->resolution, f->cg_iterations, f->updates, f->warm_start ? " (warm)" : "",
             f->residual);
}

/* The first collisions' sums (with their flux for the first-moment source). */
static int64_t solve_bytes(const vdbs_scene *scene, size_t voxels)
{
    return vdbs_collision_sum_bytes(voxels, with_p1(scene));
}

const vdbs_solver vdbs_solver_fld = {
    .name = "fld",
    .summary = "exact single scattering + flux-limited diffusion of the first-scattered light",
    .writes_ms = 1,
    .options = options,
    .option_count = (int)(sizeof options / sizeof options[0]),
    .run = run_fld,
    .stats_size = sizeof(vdbs_fld_stats),
    .report = report,
    .report_count = (int)(sizeof report / sizeof report[0]),
    .report_text = report_text,
    .state = &state,
    .solve_bytes = solve_bytes,
    .cost = {8.03, 23.4, 280, 1.04e+03}, /* bench/cost.md */
};
