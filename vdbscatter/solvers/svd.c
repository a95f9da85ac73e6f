#include "vdbscatter/svd.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"
#include "vdbscatter/coarse.h"
#include "vdbscatter/collision.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/skyfloor.h"
#include "vdbscatter/progress.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_pass.h"
#include "vs_phase.h"
#include "vs_svd.h"

/* Loop trips one GPU sweep step may spend on its chunk of directions, well under llvmpipe's
 * 65535 per invocation (vs_pass.h). */
#define SVD_GPU_TRIPS 32768
/* Default cap of source iterations. */
#define SVD_MAX_ITERATIONS 2000
/* Iterations before the contraction's estimate may end a solve that the cap would end anyway:
 * the ratio of successive changes rises towards the slowest mode's as the faster ones die. */
#define SVD_SETTLE_ITERATIONS 10
/* Iterations whose changes' mean ratio is the contraction. */
#define SVD_RATIO_SPAN 4
/* Sweeps a warm start makes before its error estimate may end it: measured on a 24-frame
 * rising plume (tests/test_sequence_cli.py). A cold bake's tail extrapolation lands it 5-10x
 * inside its residual; a warm start's contraction settles later, so it needs 11 sweeps to land
 * as near the converged ms as a cold bake (9: 1.16x the cold bake's distance on frame 12; 10:
 * 1.24x on frame 24). */
#define SVD_WARM_MIN_ITERATIONS 11

void vdbs_svd_quality(const char *quality, vdbs_svd_preset *preset)
{
    static const int directions[] = {VDBS_SVD_PRESET_DIRECTIONS},
                     resolution[] = {VDBS_SVD_PRESET_RESOLUTION},
                     across[] = {VDBS_SVD_PRESET_ACROSS};
    static const double tolerance[] = {VDBS_SVD_PRESET_TOLERANCE},
                        residual[] = {VDBS_SVD_PRESET_RESIDUAL};
    const int q = vdbs_quality_level(quality);
    *preset = (vdbs_svd_preset){directions[q], resolution[q], across[q], tolerance[q], residual[q]};
}

int vdbs_svd_terms_for(const vdbs_phasemat *pm, double tolerance)
{
    for (int n = 1; n < pm->d; ++n)
        if (vdbs_phasemat_rmse(pm, n) <= tolerance)
            return n;
    return pm->d;
}

/* The terms a solve of d keeps with this phase matrix: those asked for (at most D), else the
 * fewest within the preset's tolerance. */
static int terms_kept(const vdbs_svd_desc *d, const vdbs_svd_preset *preset,
                      const vdbs_phasemat *pm)
{
    return d->terms > 0 ? (d->terms < pm->d ? d->terms : pm->d)
                        : vdbs_svd_terms_for(pm, preset->tolerance);
}

int vdbs_svd_kept_terms(const vdbs_svd_desc *desc, const char *quality, double g)
{
    if (desc->warm)
        return desc->warm->terms;
    vdbs_svd_preset preset;
    vdbs_svd_quality(quality, &preset);
    vdbs_phasemat_desc pdesc = {desc->directions > 0 ? desc->directions : preset.directions, g,
                                desc->delta_m};
    vdbs_phasemat pm;
    vdbs_error err;
    if (vdbs_phasemat_build(&pdesc, &pm, &err) != VDBS_OK)
        return 0;
    const int terms = terms_kept(desc, &preset, &pm);
    vdbs_phasemat_free(&pm);
    return terms;
}

vdbs_status vdbs_svd_moments_alloc(vdbs_svd_moments *m, int directions, int terms, double g,
                                   size_t voxels, vdbs_error *err)
{
    memset(m, 0, sizeof *m);
    m->voxels = calloc((size_t)terms, sizeof *m->voxels);
    if (!m->voxels)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %d moment grids", terms);
    m->directions = directions;
    m->terms = terms;
    m->g = g;
    for (int k = 0; k < terms; ++k) {
        m->voxels[k] = calloc(3 * (voxels ? voxels : 1), sizeof *m->voxels[k]);
        if (!m->voxels[k]) {
            vdbs_svd_moments_free(m);
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %d moment grids", terms);
        }
    }
    return VDBS_OK;
}

void vdbs_svd_moments_free(vdbs_svd_moments *m)
{
    for (int k = 0; m->voxels && k < m->terms; ++k)
        free(m->voxels[k]);
    free(m->voxels);
    memset(m, 0, sizeof *m);
}

vdbs_status vdbs_svd_warm_check(const vdbs_svd_moments *warm, int directions, int terms, double g,
                                vdbs_error *err)
{
    if (!warm)
        return VDBS_OK;
    if (directions > 0 && directions != warm->directions)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--warm-start holds moments for %d directions, not %d",
                              warm->directions, directions);
    if (terms > 0 && terms != warm->terms)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--warm-start holds %d terms, not %d",
                              warm->terms, terms);
    if (g != warm->g)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--warm-start was solved for g = %g, this medium has g = %g", warm->g,
                              g);
    return VDBS_OK;
}

/* ---- the sweep through the runner ---- */

typedef struct svd_kernel {
    const uint32_t *params;
    const float *tables, *sigma, *direct, *source;
} svd_kernel;

VS_CPU_CLONES static double svd_step(void *user, int step, const void *state_in, void *state_out,
                                     uint64_t begin, uint64_t end)
{
    (void)state_in; /* in place: the same buffer */
    const svd_kernel *k = user;
    for (uint64_t item = begin; item < end; ++item)
        vs_svd_sweep(k->params, k->tables, k->sigma, k->direct, k->source, state_out, (int)item,
                     step);
    return 0.0;
}

/* The octant a direction is swept in (vs_svd.h). */
static int octant_of(const double w[3])
{
    return (w[0] < 0.0 ? 1 : 0) | (w[1] < 0.0 ? 2 : 0) | (w[2] < 0.0 ? 4 : 0);
}

static void put_float(uint32_t *words, int at, double value)
{
    float f = (float)value;
    memcpy(&words[at], &f, sizeof f);
}

/* Everything a sweep reads, laid out per vs_svd.h. */
typedef struct svd_layout {
    uint32_t params[VS_SVD_PARAM_WORDS];
    float *tables;
    size_t table_words;
    int *order; /* sweep position -> direction of the phase matrix */
    size_t state_words;
    int planes, chunks, chunk;
} svd_layout;

static void layout_free(svd_layout *l)
{
    free(l->tables);
    free(l->order);
}

static vdbs_status layout_build(const vdbs_svd_grid *g, int chunk, vdbs_svd_scheme scheme,
                                svd_layout *l, vdbs_error *err)
{
    memset(l, 0, sizeof *l);
    const vdbs_phasemat *pm = g->phase;
    const int D = pm->d, N = g->terms;
    l->order = malloc(sizeof *l->order * (size_t)D);
    l->table_words = (size_t)D * VS_SVD_DIR_WORDS + (size_t)D * (size_t)N +
                     (size_t)g->light_count * VS_SVD_LIGHT_WORDS;
    l->tables = malloc(sizeof *l->tables * l->table_words);
    if (!l->order || !l->tables) {
        layout_free(l);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %d directions", D);
    }
    /* Directions sorted by octant, each octant's in the matrix's order. */
    int start[VS_SVD_OCTANTS + 1] = {0}, widest = 0;
    for (int o = 0, at = 0; o < VS_SVD_OCTANTS; ++o) {
        start[o] = at;
        for (int d = 0; d < D; ++d)
            if (octant_of(pm->dirs + 3 * d) == o)
                l->order[at++] = d;
        start[o + 1] = at;
        if (at - start[o] > widest)
            widest = at - start[o];
    }
    /* D >= 2 (phasemat.h), so some octant has a direction. */
    l->chunk = chunk > 0 && chunk < widest ? chunk : widest;
    l->chunks = (widest + l->chunk - 1) / l->chunk;
    l->planes = g->n[0] + g->n[1] + g->n[2] - 2;
    const size_t v_at = (size_t)D * VS_SVD_DIR_WORDS;
    const size_t light_at = v_at + (size_t)D * (size_t)N;
    for (int s = 0; s < D; ++s) {
        const int d = l->order[s];
        float *rec = l->tables + (size_t)s * VS_SVD_DIR_WORDS;
        for (int a = 0; a < 3; ++a)
            rec[VS_SVD_DIR_W + a] = (float)pm->dirs[3 * d + a];
        rec[VS_SVD_DIR_WEIGHT] = (float)(4.0 * VDBS_PI / D);
        for (int k = 0; k < N; ++k)
            l->tables[v_at + (size_t)s * N + k] = (float)pm->eigvec[(size_t)d * D + k];
    }
    for (int i = 0; i < g->light_count; ++i) {
        float *rec = l->tables + light_at + (size_t)i * VS_SVD_LIGHT_WORDS;
        rec[VS_SVD_LIGHT_POINT] = g->lights[i].point ? 1.0f : 0.0f;
        for (int a = 0; a < 3; ++a)
            rec[VS_SVD_LIGHT_VEC + a] = (float)g->lights[i].vec[a];
    }
    const size_t cells = (size_t)g->n[0] * g->n[1] * g->n[2];
    uint32_t *p = l->params;
    for (int a = 0; a < 3; ++a) {
        p[VS_SVD_OFF_N + a] = (uint32_t)g->n[a];
        put_float(p, VS_SVD_OFF_ORIGIN + a, g->origin[a]);
        put_float(p, VS_SVD_OFF_EXTINCT + a, 1.0 - pm->f * g->albedo[a]);
        put_float(p, VS_SVD_OFF_INFLOW + a, g->inflow[a]);
    }
    const double largest = fmax(g->h[0], fmax(g->h[1], g->h[2]));
    put_float(p, VS_SVD_OFF_H, largest);
    for (int a = 0; a < 3; ++a)
        put_float(p, VS_SVD_OFF_SIDE + a, g->h[a]);
    p[VS_SVD_OFF_TERMS] = (uint32_t)N;
    p[VS_SVD_OFF_LIGHTS] = (uint32_t)g->light_count;
    put_float(p, VS_SVD_OFF_G, pm->g_scaled);
    p[VS_SVD_OFF_CHUNK] = (uint32_t)l->chunk;
    p[VS_SVD_OFF_CHUNKS] = (uint32_t)l->chunks;
    p[VS_SVD_OFF_SCHEME] = scheme == VDBS_SVD_DIAMOND ? 1u : 0u;
    for (int o = 0; o <= VS_SVD_OCTANTS; ++o)
        p[VS_SVD_OFF_OCTANT + o] = (uint32_t)start[o];
    p[VS_SVD_OFF_STATE_OUT] = (uint32_t)(cells * (size_t)N * 3);
    p[VS_SVD_OFF_STATE_PLANES] = (uint32_t)(cells * ((size_t)N * 3 + VS_SVD_OUT_WORDS));
    p[VS_SVD_OFF_TABLE_V] = (uint32_t)v_at;
    p[VS_SVD_OFF_TABLE_LIGHTS] = (uint32_t)light_at;
    l->state_words = cells * ((size_t)N * 3 + VS_SVD_OUT_WORDS) +
                     2 * (size_t)l->chunk * (size_t)g->n[0] * g->n[1] *
                         (size_t)vs_svd_face_words(scheme == VDBS_SVD_DIAMOND);
    /* The kernel indexes with 32-bit ints (GLSL). */
    if (l->state_words > (size_t)INT32_MAX || cells * (size_t)N * 3 > (size_t)INT32_MAX) {
        layout_free(l);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%zu cells x %d terms is too large for the sweep's 32-bit indices: "
                              "lower --svd-res or --svd-terms",
                              cells, N);
    }
    return VDBS_OK;
}

/* The source moments of the next sweep: s_k = sky_k + lambda_k sigma_s* m_k. */
static void next_source(const vdbs_svd_grid *g, const float *moments, float *source)
{
    const int N = g->terms;
    const int64_t cells = (int64_t)g->n[0] * g->n[1] * g->n[2];
    const double keep = 1.0 - g->phase->f;
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < cells; ++c)
        for (int k = 0; k < N; ++k)
            for (int ch = 0; ch < 3; ++ch) {
                size_t at = (size_t)vs_svd_moment_at((int)c, N, k, ch);
                double s = g->sky ? g->sky[at] : 0.0;
                if (moments)
                    s += g->phase->eigval[k] * keep * g->albedo[ch] * g->sigma_t[c] * moments[at];
                source[at] = (float)s;
            }
}

/* The stats that describe the problem rather than the iteration. */
static void stats_begin(const vdbs_svd_grid *grid, vdbs_svd_stats *stats)
{
    const vdbs_phasemat *pm = grid->phase;
    stats->directions = pm->d;
    stats->terms = grid->terms;
    stats->cells = (int64_t)grid->n[0] * grid->n[1] * grid->n[2];
    stats->cell_side = fmax(grid->h[0], fmax(grid->h[1], grid->h[2]));
    stats->delta_m_f = pm->f;
    stats->g_scaled = pm->g_scaled;
    stats->factor_rmse = vdbs_phasemat_rmse(pm, grid->terms);
    stats->warm_start = grid->warm != NULL;
    stats->iterations = 0;
    stats->converged = 0;
    stats->balance = 0.0;
    stats->clamped_fraction = 0.0;
    stats->residual = 1.0;
    stats->contraction = 0.0;
    stats->predicted_iterations = 0;
}

/* Directions per sweep step: the caller's, else on the GPU as many as keep a step's loops
 * under SVD_GPU_TRIPS (0 on the C path: a whole octant). */
static int sweep_chunk(vdbs_runner *runner, const vdbs_svd_grid *grid, vdbs_svd_scheme scheme,
                       int chunk)
{
    if (chunk > 0 || vdbs_runner_backend(runner) != VDBS_BACKEND_GPU)
        return chunk;
    /* Per direction: two loops over the terms, one over the lights, and the cell's three
     * channels (vs_svd_cell_channel): one pass over the axes in the step, which never holds a
     * face, up to three in the diamond. */
    const int cell_trips = scheme == VDBS_SVD_DIAMOND ? 48 : 16;
    chunk = SVD_GPU_TRIPS / (2 * grid->terms + grid->light_count + cell_trips);
    return chunk > 0 ? chunk : 1;
}

/* One sweep through the runner, every step of it an iteration of an in-place kernel. The
 * inputs that stay the same for the solve (parameters, tables, medium, direct light) are
 * resident on the GPU under `ids` (the caller releases them), so that a solve uploads them
 * once; the source, new every sweep, is uploaded with it, and the state starts zeroed on the
 * GPU. */
static void sweep_kernel(const vdbs_svd_grid *grid, const svd_layout *l, svd_kernel *k,
                         const uint64_t ids[4], float *state, vdbs_kernel_desc *kd)
{
    const size_t cells = (size_t)grid->n[0] * grid->n[1] * grid->n[2];
    memset(kd, 0, sizeof *kd);
    kd->items = (uint64_t)grid->n[0] * (uint64_t)grid->n[1];
    kd->user = k;
    kd->cpu_step = svd_step;
    kd->cpu_chunk = 16;
    kd->shader = "svd_sweep.comp";
    kd->inputs[1] = (vdbs_kernel_input){l->params, sizeof l->params, ids[0]};
    kd->inputs[2] = (vdbs_kernel_input){l->tables, sizeof(float) * l->table_words, ids[1]};
    kd->inputs[3] = (vdbs_kernel_input){grid->sigma_t, sizeof(float) * cells, ids[2]};
    kd->inputs[4] = (vdbs_kernel_input){
        grid->direct, sizeof(float) * 3 * cells * (size_t)grid->light_count, ids[3]};
    kd->inputs[5] = (vdbs_kernel_input){.data = k->source,
                                        .size = sizeof(float) * cells * (size_t)grid->terms * 3};
    kd->state = state;
    kd->state_zeroed = 1;
    kd->state_items = 1;
    kd->state_words = l->state_words;
    kd->in_place = 1;
    kd->max_iterations = VS_SVD_OCTANTS * l->chunks * l->planes;
    kd->reduce = VDBS_REDUCE_NONE;
}

/* The fluence's distance from the converged one, relative, estimated from the iterations'
 * relative changes (changes[0] the latest, `known` of them): source iteration shrinks its error
 * by about the ratio rho of successive changes, so what remains after a change c is about
 * c rho / (1 - rho), which in a thick medium near albedo 1 (rho near 1) is many times c. rho
 * is the mean ratio over up to SVD_RATIO_SPAN iterations, as single ratios wander once the
 * changes near float rounding. Never below c itself; a ratio of 1 or more (no contraction seen
 * yet) leaves c, and the caller does not stop on it. A change of 0 is a fixed point. */
static double remaining_error(const double *changes, int known, double *rho)
{
    const int span = known - 1 < SVD_RATIO_SPAN ? known - 1 : SVD_RATIO_SPAN;
    if (known > 0 && changes[0] == 0.0)
        *rho = 0.0; /* a fixed point, in float */
    else
        *rho = span > 0 && changes[span] > 0.0 ? pow(changes[0] / changes[span], 1.0 / span) : 1.0;
    return *rho < 1.0 ? changes[0] * fmax(1.0, *rho / (1.0 - *rho)) : changes[0];
}

/* Iterations in all that the error `remaining` after `done` of them needs to reach `target` at
 * the contraction rho (done itself once there; 0 when rho says nothing). */
static int predicted_iterations(int done, double remaining, double target, double rho)
{
    if (!(rho > 0.0 && rho < 1.0 && target > 0.0) || remaining <= target)
        return rho < 1.0 ? done : 0;
    return done + (int)fmin(ceil(log(target / remaining) / log(rho)), 1e9);
}

/* Each cell's fluence and flux words of the sweep's records (VS_SVD_OUT_FLUENCE then
 * VS_SVD_OUT_FLUX, adjacent), and where the flux starts among them. */
#define SVD_FIELD_WORDS 12
#define SVD_FIELD_FLUX 3
_Static_assert(VS_SVD_OUT_FLUX == VS_SVD_OUT_FLUENCE + SVD_FIELD_FLUX &&
                   VS_SVD_OUT_FLUENCE + SVD_FIELD_WORDS <= VS_SVD_OUT_WORDS,
               "the fluence and flux words are adjacent");

/* The fluence and flux of the last sweep into `kept` (SVD_FIELD_WORDS a cell). */
static void keep_fields(int64_t cells, const float *out, float *kept)
{
    for (int64_t c = 0; c < cells; ++c)
        memcpy(kept + (size_t)c * SVD_FIELD_WORDS,
               out + (size_t)c * VS_SVD_OUT_WORDS + VS_SVD_OUT_FLUENCE,
               sizeof *kept * SVD_FIELD_WORDS);
}

/* Sweep `it`'s tallies into stats from its per-cell records `out`: the power balance, the
 * clamp, and the fluence's relative change since the sweep before (`before`: its fields,
 * keep_fields', zeros before the first sweep), returned for remaining_error. */
static double sweep_tally(int64_t cells, int directions, const float *out, int it,
                          const float *before, vdbs_svd_stats *stats)
{
    stats->cell_direction_updates += cells * directions;
    double emitted = 0.0, collided = 0.0, leaked = 0.0, clamped = 0.0, change = 0.0, total = 0.0;
    for (int64_t c = 0; c < cells; ++c) {
        const float *rec = out + (size_t)c * VS_SVD_OUT_WORDS;
        emitted += rec[VS_SVD_OUT_SOURCE];
        collided += rec[VS_SVD_OUT_COLLIDE];
        leaked += rec[VS_SVD_OUT_LEAK];
        clamped += rec[VS_SVD_OUT_CLAMPED];
        for (int ch = 0; ch < 3; ++ch) {
            double phi = rec[VS_SVD_OUT_FLUENCE + ch];
            change += fabs(phi - before[(size_t)c * SVD_FIELD_WORDS + ch]);
            total += fabs(phi);
        }
    }
    if (it == 0)
        stats->first_power = emitted;
    stats->emitted = emitted;
    stats->collided = collided;
    stats->leaked = leaked;
    stats->clamped = clamped;
    if (emitted > 0.0)
        stats->balance = fmax(stats->balance, fabs(emitted - collided - leaked) / emitted);
    if (emitted + clamped > 0.0)
        stats->clamped_fraction = fmax(stats->clamped_fraction, clamped / (emitted + clamped));
    stats->iterations = it + 1;
    return total > 0.0 ? change / total : 0.0;
}

/* The iterations' progress: the residual's way from 1 to the target on a log scale. */
static void sweep_progress(const vdbs_svd_desc *desc, const vdbs_svd_stats *stats, int it)
{
    if (!desc->progress)
        return;
    if (it == 0)
        vdbs_progress_begin(desc->progress, desc->progress->enabled, "svd iterations", 1000);
    if (desc->residual > 0.0 && desc->residual < 1.0) {
        double done = log(fmax(stats->residual, desc->residual)) / log(desc->residual);
        vdbs_progress_update(desc->progress, (uint64_t)(1000.0 * fmin(fmax(done, 0.0), 1.0)));
    }
}

/* The solve's outputs from the last sweep's state (each may be NULL). With tail > 0 (`before`:
 * the sweep before's fields), the fluence and flux are extrapolated along the iteration's
 * slowest mode: source iteration closes the distance x* - x_k by the contraction rho a sweep,
 * so x* ~ x_k + (x_k - x_{k-1}) rho / (1 - rho) (`tail`), the same geometric tail the stopping
 * rule takes as the remaining error. The fluence stays >= 0 and each channel's flux within
 * its fluence (|sum L w dw| <= sum L dw). With `before_moments` the moments (the kept state, a
 * warm start's start) are extrapolated alike. */
static void solve_outputs(int64_t cells, int terms, const float *state, const float *out,
                          const float *before, const float *before_moments, double tail,
                          double *fluence, double *flux, float *moments)
{
    for (int64_t c = 0; c < cells; ++c) {
        const float *rec = out + (size_t)c * VS_SVD_OUT_WORDS;
        double field[SVD_FIELD_WORDS];
        for (int v = 0; v < SVD_FIELD_WORDS; ++v) {
            const double now = rec[VS_SVD_OUT_FLUENCE + v];
            field[v] =
                tail > 0.0 ? now + (now - before[(size_t)c * SVD_FIELD_WORDS + v]) * tail : now;
        }
        for (int ch = 0; ch < 3; ++ch) {
            double *x = field + SVD_FIELD_FLUX + ch, *y = x + 3, *z = x + 6;
            field[ch] = fmax(field[ch], 0.0);
            const double norm = sqrt(*x * *x + *y * *y + *z * *z);
            if (norm > field[ch]) {
                const double scale = field[ch] / norm;
                *x *= scale;
                *y *= scale;
                *z *= scale;
            }
        }
        for (int v = 0; fluence && v < 3; ++v)
            fluence[3 * c + v] = field[v];
        for (int v = 0; flux && v < 9; ++v)
            flux[9 * c + v] = field[SVD_FIELD_FLUX + v];
    }
    const size_t count = (size_t)cells * (size_t)terms * 3;
    if (moments && before_moments && tail > 0.0) {
        for (size_t i = 0; i < count; ++i)
            moments[i] = (float)(state[i] + ((double)state[i] - before_moments[i]) * tail);
    } else if (moments)
        memcpy(moments, state, sizeof *state * count);
}

vdbs_status vdbs_svd_solve_grid(vdbs_runner *runner, const vdbs_svd_grid *grid,
                                const vdbs_svd_desc *desc, double *fluence, double *flux,
                                float *moments, vdbs_svd_stats *stats, vdbs_error *err)
{
    vdbs_svd_stats local;
    if (!stats)
        stats = &local;
    stats_begin(grid, stats);
    const int64_t cells = stats->cells;
    svd_layout l;
    vdbs_status st = layout_build(grid, sweep_chunk(runner, grid, desc->scheme, desc->chunk),
                                  desc->scheme, &l, err);
    if (st != VDBS_OK)
        return st;
    stats->chunk = l.chunk;
    stats->steps_per_sweep = VS_SVD_OCTANTS * l.chunks * l.planes;
    float *state = malloc(sizeof *state * l.state_words);
    float *source = malloc(sizeof *source * (size_t)cells * grid->terms * 3);
    float *before = calloc(SVD_FIELD_WORDS * (size_t)cells, sizeof *before);
    const size_t moment_count = (size_t)cells * (size_t)grid->terms * 3;
    float *before_moments = moments ? malloc(sizeof *before_moments * moment_count) : NULL;
    const uint64_t ids[4] = {vdbs_runner_resident_id(runner), vdbs_runner_resident_id(runner),
                             vdbs_runner_resident_id(runner), vdbs_runner_resident_id(runner)};
    if (!state || !source || !before || (moments && !before_moments))
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %lld cells x %d terms",
                            (long long)cells, grid->terms);
    svd_kernel k = {l.params, l.tables, grid->sigma_t, grid->direct, source};
    vdbs_kernel_desc kd;
    sweep_kernel(grid, &l, &k, ids, state, &kd);
    kd.cancel = vdbs_progress_cancel(desc->progress);
    const size_t out = l.params[VS_SVD_OFF_STATE_OUT]; /* the per-cell records in the state */
    const int max_iterations = desc->max_iterations > 0 ? desc->max_iterations : SVD_MAX_ITERATIONS;
    double changes[SVD_RATIO_SPAN + 1] = {0.0};
    if (st == VDBS_OK)
        next_source(grid, grid->warm, source);
    for (int it = 0; it < max_iterations && st == VDBS_OK; ++it) {
        if (vdbs_cancelled(kd.cancel)) {
            st = vdbs_error_cancelled(err);
            break;
        }
        if (it > 0)
            keep_fields(cells, state + out, before);
        if (it > 0 && before_moments)
            memcpy(before_moments, state, sizeof *state * moment_count);
        /* The GPU clears its copy itself (kd.state_zeroed); the C path sweeps this one. */
        memset(state, 0, sizeof *state * l.state_words);
        if ((st = vdbs_kernel_iterate(runner, &kd, NULL, err)) != VDBS_OK)
            break;
        const double change = sweep_tally(cells, grid->phase->d, state + out, it, before, stats);
        memmove(changes + 1, changes, sizeof changes - sizeof *changes);
        changes[0] = change;
        double rho;
        /* The first sweep's change is from the start (zero, or a warm start's moments
         * against zero fluence): no step of the iteration, so no ratio uses it. */
        stats->residual = remaining_error(changes, it, &rho);
        stats->contraction = rho;
        if (grid->warm) {
            /* A warm start's first changes die with the faster modes and understate the
             * slowest: its ratio is not trusted before SVD_WARM_MIN_ITERATIONS, and never
             * below the contraction of the solve it started from. */
            if (it + 1 < SVD_WARM_MIN_ITERATIONS)
                rho = 1.0;
            else if (rho < 1.0 && grid->warm_contraction > rho && grid->warm_contraction < 1.0) {
                rho = grid->warm_contraction;
                stats->residual = changes[0] * fmax(1.0, rho / (1.0 - rho));
                stats->contraction = rho;
            }
        }
        stats->predicted_iterations =
            predicted_iterations(it + 1, stats->residual, desc->residual, rho);
        next_source(grid, state, source);
        sweep_progress(desc, stats, it);
        if (rho < 1.0 && stats->residual <= desc->residual) {
            stats->converged = 1;
            break;
        }
        /* Where the contraction, once settled, says the cap comes first, the sweeps left would
         * only be spent: stop, not converged, with the estimate reported. */
        if (desc->residual > 0.0 && it + 1 >= SVD_SETTLE_ITERATIONS &&
            stats->predicted_iterations > max_iterations)
            break;
    }
    if (st == VDBS_OK) {
        /* The tail once the contraction has been measured (it needs two changes after the
         * first sweep's), from the same rho the stopping rule used. */
        const double rho = stats->contraction;
        const int measured = stats->iterations > 2 && rho > 0.0 && rho < 1.0;
        const double tail = !desc->last_sweep && measured ? rho / (1.0 - rho) : 0.0;
        stats->extrapolated = tail;
        solve_outputs(cells, grid->terms, state, state + out, before, before_moments, tail, fluence,
                      flux, moments);
    }
    for (int i = 0; i < 4; ++i)
        vdbs_runner_release(runner, ids[i]);
    layout_free(&l);
    free(state);
    free(source);
    free(before);
    free(before_moments);
    return st;
}

/* ---- the bake ---- */

/* sum_d HG(g*, travel . w_d) dw_d in the kernel's float arithmetic: what makes the emitted
 * power of a light's first scattering exact on the directions. With `phase` (D values) also
 * each direction's HG. */
static double discrete_norm(const vdbs_phasemat *pm, const double travel[3], double *phase)
{
    pnanovdb_vec3_t t = vs_vec3((float)travel[0], (float)travel[1], (float)travel[2]);
    double sum = 0.0;
    for (int d = 0; d < pm->d; ++d) {
        const double *w = pm->dirs + 3 * d;
        double p =
            vs_hg_dirs((float)pm->g_scaled, t, vs_vec3((float)w[0], (float)w[1], (float)w[2]));
        if (phase)
            phase[d] = p;
        sum += p;
    }
    return sum * 4.0 * VDBS_PI / pm->d;
}

/* A bake's discrete-ordinates solve between vdbs_svd_begin and vdbs_svd_end. */
struct vdbs_svd_run {
    const vdbs_solve *s;
    vdbs_svd_desc desc;
    vdbs_svd_stats stats;
    double t0;
    vdbs_phasemat pm;
    int terms;
    vdbs_coarse_frame f;
    int64_t cells;
    vdbs_medium_box box;
    float *sigma, *direct, *sky, *warm, *moments;
    vdbs_svd_light *lights;
    double *scatter; /* 3 per output voxel: one light's sigma_s* E T*, the voxel's average */
    double *beam;    /* VDBS_COLLISION_SCRATCH per output voxel: vdbs_first_collisions' */
    vdbs_voxel_faces faces;
    double *acc;     /* 3 per cell: the same splatted */
    double *project; /* N: a sky ordinate's emission projected on the v_k */
    double *phase;   /* D: a sky ordinate's HG toward every direction */
    double *fluence, *flux, *values;
    vdbs_sky_floor floor; /* the sky's uniform part, through the boundary (skyfloor.h) */
};

int64_t vdbs_svd_voxel_bytes(size_t voxels)
{
    const vdbs_svd_run *r = NULL; /* sizeof only: the fields' types, as vdbs_svd_begin allocates */
    return vdbs_voxel_faces_bytes(voxels) +
           (int64_t)((3 * sizeof *r->scatter + VDBS_COLLISION_SCRATCH * sizeof *r->beam) * voxels);
}

/* One light's first scattering in the scaled problem, from the optical depth toward it at
 * every output voxel (the S1 pass's light grids, vdbs_s1_outputs.light_depth): per voxel
 * sigma_s* E T*, T* = exp(-(1 - f albedo) tau), averaged over the voxel (vdbs_first_collisions:
 * the point value at the centre undercounts optically thick voxels), times its volume,
 * splatted into the cells (vdbs_coarse_splat keeps the total); a direct light keeps it per
 * cell over its discrete normalisation (vs_svd.h), a sky ordinate's emission is projected on
 * the v_k. With delta-M the scaled beam also carries the light scattered only into the
 * forward peak, E (T* - T): it has scattered, so it is Sms's (docs/design.md), and it goes
 * into ms and ms_l1 at the voxels themselves, a collimated beam along the light's travel
 * (vdbs_svd_finish adds ms to radiance). */
void vdbs_svd_light_depth(void *user, int light, const float *depth)
{
    vdbs_svd_run *r = user;
    const vdbs_solve *s = r->s;
    const vdbs_volume *volume = s->volume;
    const vdbs_phasemat *pm = &r->pm;
    const double l1 = 3.0 * s->scene->g * VDBS_INV_4PI;
    const int64_t count = (int64_t)volume->coord_count;
    /* sigma_s* = (1 - f) albedo sigma_t = (1 - f) albedo / k sigma_t*, k = 1 - f albedo. */
    double k[3], share[3];
    for (int ch = 0; ch < 3; ++ch) {
        const double albedo = s->scene->albedo[ch];
        k[ch] = 1.0 - pm->f * albedo;
        share[ch] = k[ch] > 0.0 ? (1.0 - pm->f) * albedo / k[ch] : 0.0;
    }
    vdbs_first_collisions(volume, &r->faces, s->lights, light, depth, s->scene->density_scale, k,
                          r->beam, r->scatter, NULL);
    /* A sky ordinate less the sky's uniform part, which enters through the boundary. */
    double rest[3] = {1.0, 1.0, 1.0};
    if (light >= s->lights->direct_count && vdbs_sky_floor_active(&r->floor))
        vdbs_sky_floor_light(&r->floor, volume, s->lights, light, depth, rest);
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        for (int ch = 0; ch < 3; ++ch)
            r->scatter[3 * n + ch] *= share[ch] * rest[ch];
        if (pm->f > 0.0) {
            double w[3], color[3], travel[3];
            vdbs_volume_voxel_point(volume, (size_t)n, w);
            vdbs_lights_arrival(s->lights, light, w, color, travel);
            for (int ch = 0; ch < 3; ++ch) {
                const double peak = rest[ch] * color[ch] *
                                    (vdbs_beam_transmittance(k[ch], depth[n]) -
                                     vdbs_beam_transmittance(1.0, depth[n]));
                s->ms[3 * n + ch] += (float)(peak * VDBS_INV_4PI);
                for (int ax = 0; ax < 3; ++ax)
                    s->ms_l1[ax][3 * n + ch] += (float)(l1 * peak * travel[ax]);
            }
        }
    }
    const double scale = vdbs_volume_voxel_volume(volume) / vdbs_coarse_cell_volume(&r->f);
    memset(r->acc, 0, sizeof *r->acc * 3 * (size_t)r->cells);
    for (int64_t n = 0; n < count; ++n) {
        const double *q = r->scatter + 3 * n;
        if (!(q[0] > 0.0 || q[1] > 0.0 || q[2] > 0.0))
            continue;
        double w[3];
        vdbs_volume_voxel_point(volume, (size_t)n, w);
        vdbs_coarse_splat(&r->f, r->acc, 3, w, q, scale);
    }
    const vdbs_light_table *lt = s->lights;
    const int L = lt->direct_count, terms = r->terms;
    if (light < L) {
        double travel[3], color[3], norm = 0.0;
        for (int64_t c = 0; c < r->cells; ++c) {
            if (c == 0 || r->lights[light].point) {
                double centre[3];
                vdbs_coarse_cell_centre(&r->f, c, centre);
                vdbs_lights_arrival(lt, light, centre, color, travel);
                norm = discrete_norm(pm, travel, NULL);
            }
            for (int ch = 0; ch < 3; ++ch)
                r->direct[((size_t)c * L + light) * 3 + ch] =
                    norm > 0.0 ? (float)(r->acc[3 * c + ch] / norm) : 0.0f;
        }
        return;
    }
    /* A sky ordinate: its emission HG(g*, travel . w_d) / norm projected on every v_k. */
    double travel[3], color[3], origin[3] = {0.0, 0.0, 0.0};
    vdbs_lights_arrival(lt, light, origin, color, travel);
    const double norm = discrete_norm(pm, travel, r->phase);
    memset(r->project, 0, sizeof *r->project * (size_t)terms);
    for (int d = 0; d < pm->d; ++d) {
        const double p = r->phase[d] / norm;
        for (int k = 0; k < terms; ++k)
            r->project[k] += pm->eigvec[(size_t)d * pm->d + k] * p;
    }
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < r->cells; ++c) {
        const double *a = r->acc + 3 * c;
        if (a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0)
            continue;
        for (int k = 0; k < terms; ++k)
            for (int ch = 0; ch < 3; ++ch)
                r->sky[vs_svd_moment_at((int)c, terms, k, ch)] += (float)(a[ch] * r->project[k]);
    }
}

/* --warm-start: each cell the mean of the voxels whose centres lie in it (0 where none has a
 * value: there the iteration starts cold). Returns the cells that got a value; 0 (no overlap
 * with the file's volume, or out of memory) is a cold start. */
static int64_t moments_from_voxels(const vdbs_volume *volume, const vdbs_coarse_frame *f, int terms,
                                   const float *const *voxels, float *cells_out)
{
    const int64_t cells = vdbs_coarse_cells(f);
    int *count = calloc((size_t)cells, sizeof *count);
    double *sum = calloc((size_t)cells * terms * 3, sizeof *sum);
    if (!count || !sum) {
        free(count);
        free(sum);
        return 0;
    }
    for (size_t n = 0; n < volume->coord_count; ++n) {
        double w[3];
        vdbs_volume_voxel_point(volume, n, w);
        int at[3], inside = 1;
        for (int a = 0; a < 3; ++a) {
            at[a] = (int)floor((w[a] - f->origin[a]) / f->side[a]);
            inside &= at[a] >= 0 && at[a] < f->n[a];
        }
        /* A voxel the file had no value for (new since it was baked: a sequence's box
         * grows) reads all 0: it says nothing of its cell, which keeps the others' mean. */
        int known = 0;
        for (int k = 0; k < terms && !known; ++k)
            known = voxels[k][3 * n] != 0.0f || voxels[k][3 * n + 1] != 0.0f ||
                    voxels[k][3 * n + 2] != 0.0f;
        if (!inside || !known)
            continue;
        size_t cell = ((size_t)at[2] * f->n[1] + at[1]) * f->n[0] + at[0];
        ++count[cell];
        for (int k = 0; k < terms; ++k)
            for (int ch = 0; ch < 3; ++ch)
                sum[vs_svd_moment_at((int)cell, terms, k, ch)] += voxels[k][3 * n + ch];
    }
    int64_t filled = 0;
    for (int64_t c = 0; c < cells; ++c) {
        filled += count[c] > 0;
        for (int v = 0; v < terms * 3; ++v)
            cells_out[(size_t)c * terms * 3 + v] =
                count[c] ? (float)(sum[(size_t)c * terms * 3 + v] / count[c]) : 0.0f;
    }
    free(count);
    free(sum);
    return filled;
}

/* --keep-state: the moments at every output voxel, trilinear from the cells. */
static void moments_to_voxels(const vdbs_volume *volume, const vdbs_coarse_frame *f, int terms,
                              const float *moments, float **voxels)
{
    const int64_t count = (int64_t)volume->coord_count;
#pragma omp parallel
    {
        double *v = malloc(sizeof *v * 3 * (size_t)terms);
#pragma omp for schedule(static)
        for (int64_t n = 0; n < count; ++n) {
            double w[3];
            vdbs_volume_voxel_point(volume, (size_t)n, w);
            if (v)
                vdbs_coarse_sample(f, moments, 3 * terms, w, v);
            for (int k = 0; k < terms; ++k)
                for (int ch = 0; ch < 3; ++ch)
                    voxels[k][3 * n + ch] = v ? (float)v[vs_svd_moment_at(0, terms, k, ch)] : 0.0f;
        }
        free(v);
    }
}

void vdbs_svd_end(vdbs_svd_run *r)
{
    if (!r)
        return;
    vdbs_medium_box_free(&r->box);
    vdbs_phasemat_free(&r->pm);
    free(r->sigma);
    free(r->direct);
    free(r->sky);
    free(r->warm);
    free(r->moments);
    free(r->lights);
    free(r->scatter);
    free(r->beam);
    vdbs_voxel_faces_free(&r->faces);
    free(r->acc);
    free(r->project);
    free(r->phase);
    free(r->fluence);
    free(r->flux);
    free(r->values);
    vdbs_sky_floor_free(&r->floor);
    free(r);
}

vdbs_status vdbs_svd_begin(const vdbs_solve *s, const vdbs_svd_desc *desc, vdbs_svd_run **out,
                           vdbs_error *err)
{
    *out = NULL;
    vdbs_svd_desc d = desc ? *desc : (vdbs_svd_desc){0};
    vdbs_svd_preset preset;
    vdbs_svd_quality(s->quality ? s->quality->name : NULL, &preset);
    vdbs_status st = vdbs_svd_warm_check(d.warm, d.directions, d.terms, s->scene->g, err);
    if (st != VDBS_OK)
        return st;
    if (d.warm) {
        d.directions = d.warm->directions;
        d.terms = d.warm->terms;
    }
    if (d.directions <= 0)
        d.directions = preset.directions;
    if (!(d.residual > 0.0))
        d.residual = preset.residual;
    vdbs_svd_run *r = calloc(1, sizeof *r);
    if (!r)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    r->s = s;
    r->desc = d;
    r->t0 = vdbs_now();
    vdbs_phasemat_desc pdesc = {d.directions, s->scene->g, d.delta_m};
    st = vdbs_phasemat_build(&pdesc, &r->pm, err);
    if (st != VDBS_OK) {
        vdbs_svd_end(r);
        return st;
    }
    r->terms = terms_kept(&d, &preset, &r->pm);
    r->stats.resolution =
        vdbs_coarse_world_frame(s->volume, d.resolution > 0 ? d.resolution : preset.resolution,
                                d.across > 0 ? d.across : preset.across, &r->f);
    r->cells = vdbs_coarse_cells(&r->f);
    const int64_t cells = r->cells;
    const size_t voxels = s->volume->coord_count ? s->volume->coord_count : 1;
    const int L = s->lights->direct_count;
    /* The medium box-filtered at the shortest side: a thin axis keeps its profile. */
    int block = (int)floor(fmin(r->f.side[0], fmin(r->f.side[1], r->f.side[2])) /
                           s->volume->mean_voxel_size);
    st = vdbs_medium_box_build(s->volume, block < 1 ? 1 : block, &r->box, err);
    if (st != VDBS_OK) {
        vdbs_svd_end(r);
        return st;
    }
    const size_t moment_floats = (size_t)cells * r->terms * 3;
    r->sigma = malloc(sizeof *r->sigma * (size_t)cells);
    r->direct = calloc((size_t)cells * 3 * (L > 0 ? L : 1), sizeof *r->direct);
    r->sky = calloc(moment_floats, sizeof *r->sky);
    r->warm = d.warm ? malloc(sizeof *r->warm * moment_floats) : NULL;
    r->moments = d.keep ? malloc(sizeof *r->moments * moment_floats) : NULL;
    r->lights = calloc((size_t)(L > 0 ? L : 1), sizeof *r->lights);
    r->scatter = malloc(sizeof *r->scatter * 3 * voxels);
    r->beam = malloc(sizeof *r->beam * VDBS_COLLISION_SCRATCH * voxels);
    r->acc = malloc(sizeof *r->acc * 3 * (size_t)cells);
    r->project = malloc(sizeof *r->project * (size_t)r->terms);
    r->phase = malloc(sizeof *r->phase * (size_t)r->pm.d);
    r->fluence = calloc(3 * (size_t)cells, sizeof *r->fluence);
    r->flux = calloc(9 * (size_t)cells, sizeof *r->flux);
    r->values = calloc(VDBS_COARSE_WIDTH * (size_t)cells, sizeof *r->values);
    if (!r->sigma || !r->direct || !r->sky || (d.warm && !r->warm) || (d.keep && !r->moments) ||
        !r->lights || !r->scatter || !r->beam || !r->acc || !r->project || !r->phase ||
        !r->fluence || !r->flux || !r->values) {
        vdbs_svd_end(r);
        return vdbs_error_set(err, VDBS_ERR_NOMEM,
                              "out of memory for the discrete ordinates' %lld cells x %d terms",
                              (long long)cells, r->terms);
    }
    st = vdbs_voxel_faces_build(s->volume, &r->faces, err);
    if (st == VDBS_OK && d.sky_boundary)
        st = vdbs_sky_floor_init(&r->floor, s->volume, s->lights, err);
    if (st != VDBS_OK) {
        vdbs_svd_end(r);
        return st;
    }
    vdbs_coarse_sigma(&r->f, s->volume, &r->box, s->scene->density_scale, r->sigma);
    for (int l = 0; l < L; ++l) {
        const vdbs_direct_light *dl = &s->lights->direct[l];
        r->lights[l].point = dl->type == VDBS_LIGHT_POINT;
        memcpy(r->lights[l].vec, dl->world, sizeof r->lights[l].vec);
    }
    /* A file whose volume does not overlap this one's starts nothing: cold, and said so. */
    if (r->warm && moments_from_voxels(s->volume, &r->f, r->terms,
                                       (const float *const *)d.warm->voxels, r->warm) == 0) {
        free(r->warm);
        r->warm = NULL;
    }
    *out = r;
    return VDBS_OK;
}

vdbs_status vdbs_svd_finish(vdbs_svd_run *r, vdbs_svd_stats *stats, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    vdbs_svd_desc *d = &r->desc;
    vdbs_status st = VDBS_OK;
    if (d->keep)
        st = vdbs_svd_moments_alloc(d->keep, r->pm.d, r->terms, s->scene->g, s->volume->coord_count,
                                    err);
    r->stats.seconds_source = vdbs_now() - r->t0;
    if (st == VDBS_OK) {
        vdbs_svd_grid grid = {{r->f.n[0], r->f.n[1], r->f.n[2]},
                              {r->f.side[0], r->f.side[1], r->f.side[2]},
                              {r->f.origin[0], r->f.origin[1], r->f.origin[2]},
                              r->sigma,
                              {s->scene->albedo[0], s->scene->albedo[1], s->scene->albedo[2]},
                              &r->pm,
                              r->terms,
                              r->lights,
                              s->lights->direct_count,
                              r->direct,
                              r->sky,
                              r->warm,
                              {r->floor.radiance[0], r->floor.radiance[1], r->floor.radiance[2]},
                              d->warm ? d->warm->contraction : 0.0};
        double t1 = vdbs_now();
        st = vdbs_svd_solve_grid(s->runner, &grid, d, r->fluence, r->flux, r->moments, &r->stats,
                                 err);
        r->stats.seconds_solve = vdbs_now() - t1;
        if (d->keep)
            d->keep->contraction = r->stats.contraction;
    }
    if (st == VDBS_OK) {
        double t2 = vdbs_now();
        /* ms holds the forward peak's light so far (vdbs_svd_light_depth): into radiance too. */
        for (size_t v = 0; v < 3 * s->volume->coord_count; ++v)
            s->radiance[v] += s->ms[v];
        /* docs/design.md's ms and ms_l1 with the medium's g (the full phase's first moment). */
        vdbs_sky_floor_take_flux(&r->floor, s->volume, &r->f, r->flux);
        vdbs_coarse_ms_values(r->cells, r->fluence, r->flux, s->scene->g, r->values);
        /* Through the cell values: the interpolating B-spline (docs/design.md "Upsampling
         * without seams"). */
        st = vdbs_coarse_upsample(&r->f, r->values, s->volume, &r->box, s->scene->density_scale,
                                  VDBS_COARSE_BSPLINE_INTERP, s->ms, s->ms_l1, s->radiance, err);
        if (st == VDBS_OK)
            vdbs_sky_floor_remove(&r->floor, s->volume->coord_count, s->ms, s->radiance);
        if (st == VDBS_OK && r->moments)
            moments_to_voxels(s->volume, &r->f, r->terms, r->moments, d->keep->voxels);
        r->stats.seconds_upsample = vdbs_now() - t2;
    }
    if (st != VDBS_OK && d->keep)
        vdbs_svd_moments_free(d->keep);
    if (stats)
        *stats = r->stats;
    return st;
}
