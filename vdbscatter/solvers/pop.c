#include "vdbscatter/pop.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/coarse.h"
#include "vdbscatter/importance.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/radial.h"
#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_pop.h"

#define POP_DEFAULT_EPSILON_A 0.1
/* The default resolution, cells across the largest extent. POP's image error grows as its
 * cells shrink on every scene measured (bench/pop.md: the sphere and cloud samples, g 0 / 0.5 /
 * 0.85, and the POP check scene), and no mean-free-path rule follows the optimum (it sits
 * at 2-4 cells while sigma_tr spans 0.5 to 14 per unit). With the chord tally, 3 cells is
 * best on six of the seven scenes but 0.07 worse than 4 on the check scene; 4 has the lowest
 * worst case and beats the paper's tally at its best default (3) on all seven. */
#define POP_DEFAULT_RESOLUTION 4
/* Sub-columns per cell and axis that seed a cell from the fine S1 grid, at most. */
#define POP_SEED_SUBCOLUMNS 64
/* Chunks of columns (texels) whose seeded power is summed apart and then added in chunk order:
 * an OpenMP reduction adds in an order set by the thread count and the dynamic schedule, and
 * the seeded power sets the propagation's tolerance, so the grids would depend on the
 * threads. The count is fixed, not the threads'. */
#define POP_SEED_CHUNKS 256

void vdbs_pop_quality(const char *quality, int *ordinates, double *epsilon_l, int *radial)
{
    static const struct {
        int ordinates;
        double epsilon_l;
        int radial;
    } presets[] = {{8, 1e-2, 8}, {8, 1e-3, 16}, {8, 1e-4, 32}, {8, 1e-5, 64}};
    /* 8 sky grids at every quality: more raised the error on the sky-lit calibration scenes
     * (docs/planner.md, "Ladders"); the radial grids of point lights keep refining. */
    const int q = vdbs_quality_level(quality);
    *ordinates = presets[q].ordinates;
    *epsilon_l = presets[q].epsilon_l;
    if (radial)
        *radial = presets[q].radial;
}

/* ---- the solve ---- */

typedef struct pop_run {
    const vdbs_solve *s;
    vdbs_pop_desc desc;
    vdbs_pop_transport transport; /* desc's decay law and tally */
    vdbs_pop_stats *stats;
    vdbs_light_table lights; /* the suns and POP's sky ordinates */
    vdbs_light_grids fine;   /* their S1 grids */
    vdbs_medium_box box;
    double h;                 /* cell side of the directional grids */
    vdbs_coarse_frame merged; /* world-aligned, side h / 2: the accumulated ms and ms_l1 */
    double *merged_acc;       /* VDBS_COARSE_WIDTH per merged cell */
    float *merged_sigma;      /* sigma_t per merged cell: > 0 where the medium is */
    vdbs_coarse_frame iso;    /* world-aligned, side h: the isotropic residuum */
    double *iso_residual;     /* 3 per iso cell: the directional grids' light still in transit */
} pop_run;

static void run_free(pop_run *r)
{
    vdbs_lights_free(&r->lights);
    vdbs_light_grids_free(&r->fine);
    vdbs_medium_box_free(&r->box);
    free(r->merged_acc);
    free(r->merged_sigma);
    free(r->iso_residual);
}

/* The first column of seed chunk `chunk` of `columns`. */
static int seed_chunk_begin(int columns, int chunk)
{
    return (int)((int64_t)columns * chunk / POP_SEED_CHUNKS);
}

/* Seeds the state of one directional grid (light `l` of the POP table): per cell the mean over
 * sub-columns of albedo E (T_in - T_out) from the fine grid, as a lobe of anisotropy a0;
 * returns the seeded sum over cells and channels, and in *beam the same sum of what the beam
 * loses over each whole sub-column, albedo E (1 - T) with T looked up far beyond the grid's
 * end (equal when the grid holds all of the medium and no cell's share is lost). */
static double seed_grid(const pop_run *r, int l, const vdbs_coarse_frame *f, const double e[3],
                        double a0, const float *sigma, float *state, double *beam)
{
    const vdbs_solve *s = r->s;
    const double *albedo = s->scene->albedo;
    /* Sub-columns half a voxel apart, as the fine grid's own columns at its default
     * oversampling (one per voxel errs by 2% on the cube sample's sharp edges). */
    int sub = (int)ceil(2.0 * f->h / s->volume->mean_voxel_size - 1e-9);
    sub = sub < 1 ? 1 : (sub > POP_SEED_SUBCOLUMNS ? POP_SEED_SUBCOLUMNS : sub);
    const int n0 = f->n[0], n1 = f->n[1], n2 = f->n[2];
    double part[POP_SEED_CHUNKS][2] = {{0.0}};
#pragma omp parallel for schedule(dynamic, 1)
    for (int chunk = 0; chunk < POP_SEED_CHUNKS; ++chunk) {
        double total = 0.0, beam_total = 0.0;
        for (int col = seed_chunk_begin(n0 * n1, chunk); col < seed_chunk_begin(n0 * n1, chunk + 1);
             ++col) {
            int i = col % n0, j = col / n0;
            for (int p = 0; p < sub * sub; ++p) {
                double x[3] = {i + (p % sub + 0.5) / sub, j + (p / sub + 0.5) / sub, 0.0};
                double t_prev = 1.0;
                for (int k = 0; k < n2; ++k) {
                    double w[3], idx[3];
                    x[2] = k + 1.0;
                    vdbs_coarse_point(f, x, w);
                    vdbs_volume_index_point(s->volume, w, idx);
                    double t = exp(-(double)vdbs_light_grids_depth(&r->fine, l, idx));
                    double lost = (t_prev - t) / (sub * sub);
                    t_prev = t;
                    float *cell = state + ((int64_t)(k * n1 + j) * n0 + i) * VS_POP_STATE_WORDS;
                    for (int c = 0; c < 3; ++c) {
                        double v = albedo[c] * e[c] * lost;
                        cell[VS_POP_STATE_L + c] += (float)v;
                        total += v;
                    }
                }
                double w[3], idx[3];
                x[2] = n2 + 4.0;
                vdbs_coarse_point(f, x, w);
                vdbs_volume_index_point(s->volume, w, idx);
                double lost =
                    -expm1(-(double)vdbs_light_grids_depth(&r->fine, l, idx)) / (sub * sub);
                for (int c = 0; c < 3; ++c)
                    beam_total += albedo[c] * e[c] * lost;
            }
        }
        part[chunk][0] = total;
        part[chunk][1] = beam_total;
    }
    double total = 0.0;
    *beam = 0.0;
    for (int chunk = 0; chunk < POP_SEED_CHUNKS; ++chunk) {
        total += part[chunk][0];
        *beam += part[chunk][1];
    }
    const int64_t cells = vdbs_coarse_cells(f);
    const vdbs_pop_absorption absorption = {sigma, albedo, f->h};
    vdbs_pop_start_lobes(state, cells, a0, r->desc.tally_cell, NULL, &absorption);
    return total;
}

/* Eq. 10 with the chosen decay law, cells `spacing` apart: iterations until a0 falls below
 * epsilon_a, at least the cells along the grid (light from the first row must cross it), at
 * most the cap. */
static int anisotropic_iterations(const pop_run *r, int cells_along, double spacing, double a0,
                                  double mean_sigma_s)
{
    const double g = r->s->scene->g;
    double m = 0.0;
    if (fabs(a0) > r->desc.epsilon_a && mean_sigma_s > 0.0) {
        double per_cell;
        if (r->desc.decay == VDBS_POP_DECAY_PAPER)
            per_cell = g > 0.0 ? -mean_sigma_s * spacing * log(g) : HUGE_VAL;
        else
            per_cell = mean_sigma_s * spacing * (1.0 - g);
        m = per_cell > 0.0 ? log(fabs(a0) / r->desc.epsilon_a) / per_cell : HUGE_VAL;
    }
    m = fmax(m, (double)cells_along);
    return (int)fmin(m, (double)r->desc.max_iterations);
}

/* Propagates one grid of the anisotropic stage through the runner and counts it in the stats:
 * its time, cell updates and the most iterations any grid ran. */
static vdbs_status propagate_counted(pop_run *r, const uint32_t *params, size_t words,
                                     const float *sigma, int64_t cells, float *state,
                                     int max_iterations, double tolerance, vdbs_error *err)
{
    if (vdbs_progress_cancelled(r->s->progress))
        return vdbs_error_cancelled(err);
    double t0 = vdbs_now(), left = 0.0;
    int iterations = 0;
    vdbs_status st = vdbs_pop_propagate(r->s->runner, params, words, sigma, cells, state,
                                        max_iterations, tolerance, &iterations, &left, err);
    r->stats->seconds_propagate += vdbs_now() - t0;
    r->stats->cell_updates += (double)cells * iterations;
    if (iterations > r->stats->iterations_anisotropic)
        r->stats->iterations_anisotropic = iterations;
    return st;
}

/* A grid's zeroed state and its sigma_t per cell (the caller frees both). */
static vdbs_status grid_arrays(const pop_run *r, const vdbs_coarse_frame *f, float **state,
                               float **sigma, vdbs_error *err)
{
    const int64_t cells = vdbs_coarse_cells(f);
    *state = calloc((size_t)cells * VS_POP_STATE_WORDS, sizeof **state);
    *sigma = malloc(sizeof **sigma * (size_t)cells);
    if (!*state || !*sigma) {
        free(*state);
        free(*sigma);
        *state = *sigma = NULL;
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a POP grid of %lld cells",
                              (long long)cells);
    }
    vdbs_coarse_sigma(f, r->s->volume, &r->box, r->s->scene->density_scale, *sigma);
    return VDBS_OK;
}

/* Splats one cell's values of frame f into the merged grid's cells of medium: at its centre,
 * or, where the merged cells are less than half as wide (point lights refine the merged grid),
 * split into m^3 parts so that a large cell does not land on 8 small ones. Returns the share
 * that landed (a part with no cell of medium around it merges nothing). */
static double splat_cell(const pop_run *r, const vdbs_coarse_frame *f, int64_t c, const double *v,
                         double scale)
{
    const vdbs_coarse_frame *merged = &r->merged;
    int m = (int)ceil(f->h / (2.0 * merged->h) - 1e-9);
    double x[3] = {(double)(c % f->n[0]), (double)((c / f->n[0]) % f->n[1]),
                   (double)(c / ((int64_t)f->n[0] * f->n[1]))};
    if (m <= 1) {
        double w[3];
        vdbs_coarse_cell_centre(f, c, w);
        return vdbs_coarse_splat_masked(merged, r->merged_acc, VDBS_COARSE_WIDTH, w, v, scale,
                                        r->merged_sigma);
    }
    int landed = 0;
    for (int p = 0; p < m * m * m; ++p) {
        double y[3] = {x[0] + (p % m + 0.5) / m, x[1] + ((p / m) % m + 0.5) / m,
                       x[2] + (p / (m * m) + 0.5) / m},
               w[3];
        vdbs_coarse_point(f, y, w);
        landed += vdbs_coarse_splat_masked(merged, r->merged_acc, VDBS_COARSE_WIDTH, w, v,
                                           scale / (m * m * m), r->merged_sigma);
    }
    return (double)landed / (m * m * m);
}

static vdbs_status propagate_grid(pop_run *r, int l, const double d[3], const double e[3],
                                  double a0, double mean_sigma_s, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    double corners[8][3], axis[3][3];
    vdbs_volume_support_corners(s->volume, corners);
    memcpy(axis[2], d, sizeof axis[2]);
    vdbs_ortho_basis(d, axis[0], axis[1]);
    vdbs_coarse_frame f;
    vdbs_coarse_fit(corners, axis, r->h, &f);
    const int64_t cells = vdbs_coarse_cells(&f);
    double t0 = vdbs_now();
    float *state, *sigma;
    vdbs_status st = grid_arrays(r, &f, &state, &sigma, err);
    if (st != VDBS_OK)
        return st;
    r->stats->cells += cells;
    double beam = 0.0;
    double seeded = seed_grid(r, l, &f, e, a0, sigma, state, &beam);
    r->stats->seeded += seeded * f.h * f.h * f.h;
    r->stats->beam_loss += beam * f.h * f.h * f.h;
    double t1 = vdbs_now();
    r->stats->seconds_seed += t1 - t0;
    uint32_t params[VS_POP_PARAM_WORDS];
    vdbs_pop_grid_params(f.n, f.h, s->scene->g, s->scene->albedo, &r->transport, 1, params);
    if (seeded > 0.0)
        st = propagate_counted(r, params, VS_POP_PARAM_WORDS, sigma, cells, state,
                               anisotropic_iterations(r, f.n[2], f.h, a0, mean_sigma_s),
                               r->desc.epsilon_l * seeded, err);
    double t2 = vdbs_now();
    if (st == VDBS_OK) {
        /* Splat the accumulated lobes (ms, ms_l1) into the merged grid and the light still in
         * transit into the isotropic one; the ratio of cell volumes keeps the energy. A cell of
         * vacuum merges no lobes: no voxel scatters or absorbs there, and its splat put light
         * that had left the medium onto the medium cells beside it (in the extremes matrix the
         * outputs then absorbed up to 2000 times the power that entered). */
        const double scale = pow(f.h / r->merged.h, 3.0), g = s->scene->g;
        for (int64_t c = 0; c < cells; ++c) {
            const float *cell = state + c * VS_POP_STATE_WORDS;
            double v[VDBS_COARSE_WIDTH];
            int any = 0;
            for (int ch = 0; ch < 3; ++ch) {
                v[VDBS_COARSE_MS + ch] = cell[VS_POP_STATE_ACC_L + ch] * VDBS_INV_4PI;
                for (int a = 0; a < 3; ++a)
                    v[VDBS_COARSE_L1 + 3 * a + ch] =
                        3.0 * g * cell[VS_POP_STATE_ACC_LA + ch] * d[a] * VDBS_INV_4PI;
                any |= cell[VS_POP_STATE_ACC_L + ch] != 0.0f || cell[VS_POP_STATE_L + ch] != 0.0f;
            }
            if (!any)
                continue;
            double w[3];
            vdbs_coarse_cell_centre(&f, c, w);
            if (sigma[c] > 0.0f) {
                const double landed = splat_cell(r, &f, c, v, scale);
                for (int ch = 0; ch < 3; ++ch)
                    r->stats->merge_in += landed * cell[VS_POP_STATE_ACC_L + ch] * f.h * f.h * f.h;
            }
            double residual[3] = {cell[VS_POP_STATE_L], cell[VS_POP_STATE_L + 1],
                                  cell[VS_POP_STATE_L + 2]};
            if (residual[0] != 0.0 || residual[1] != 0.0 || residual[2] != 0.0)
                vdbs_coarse_splat(&r->iso, r->iso_residual, 3, w, residual,
                                  pow(f.h / r->iso.h, 3.0));
        }
        r->stats->seconds_merge += vdbs_now() - t2;
    }
    free(state);
    free(sigma);
    return st;
}

/* Seeds a point light's radial grid: per cell the power first scattered in it, albedo I times
 * the sum over sub-rays of dOmega (T(r_k) - T(r_k+1)) with T from the fine radial S1 grid, as
 * a lobe of anisotropy g about the radial direction with L = power / A(cell). Returns the
 * seeded power (summed over channels) and in *beam what the sub-rays lose in all. */
static double seed_radial(const pop_run *r, int l, const vdbs_radial_frame *f, double r_out,
                          const float *sigma, float *state, double *beam)
{
    const vdbs_solve *s = r->s;
    const vdbs_direct_light *dl = &r->lights.direct[l];
    const double *albedo = s->scene->albedo, g = s->scene->g;
    const int n0 = f->n[0], n1 = f->n[1], n2 = f->n[2];
    /* Sub-rays about two voxels apart where the grid ends. */
    int sub = (int)ceil(r_out * sqrt(f->omega[0]) / (2.0 * s->volume->mean_voxel_size));
    sub = sub < 2 ? 2 : (sub > 16 ? 16 : sub);
    double part[POP_SEED_CHUNKS][2] = {{0.0}};
#pragma omp parallel for schedule(dynamic, 1)
    for (int chunk = 0; chunk < POP_SEED_CHUNKS; ++chunk) {
        double total = 0.0, beam_total = 0.0;
        for (int t = seed_chunk_begin(n0 * n1, chunk); t < seed_chunk_begin(n0 * n1, chunk + 1);
             ++t) {
            const int i = t % n0, j = t / n0;
            double dom_sum = 0.0, d[3];
            for (int p = 0; p < sub * sub; ++p)
                dom_sum += vdbs_radial_direction(f, i + (p % sub + 0.5) / sub,
                                                 j + (p / sub + 0.5) / sub, d);
            for (int p = 0; p < sub * sub; ++p) {
                double dom = vdbs_radial_direction(f, i + (p % sub + 0.5) / sub,
                                                   j + (p / sub + 0.5) / sub, d);
                dom *= f->omega[t] / dom_sum;
                double t_prev = 1.0;
                for (int k = 0; k <= n2; ++k) {
                    /* k == n2: far beyond the grid, for the beam's whole loss. */
                    double radius = k < n2 ? f->radius[k + 1] : 2.0 * r_out + 1.0, w[3], idx[3];
                    for (int a = 0; a < 3; ++a)
                        w[a] = f->centre[a] + radius * d[a];
                    vdbs_volume_index_point(s->volume, w, idx);
                    double tr = exp(-(double)vdbs_light_grids_depth(&r->fine, l, idx));
                    if (k == n2) {
                        for (int c = 0; c < 3; ++c)
                            beam_total += albedo[c] * dl->color[c] * dom * (1.0 - tr);
                        break;
                    }
                    double lost = (t_prev - tr) * dom;
                    t_prev = tr;
                    float *cell = state + ((int64_t)k * n0 * n1 + t) * VS_POP_STATE_WORDS;
                    for (int c = 0; c < 3; ++c) {
                        double v = albedo[c] * dl->color[c] * lost;
                        cell[VS_POP_STATE_L + c] += (float)v;
                        total += v;
                    }
                }
            }
        }
        part[chunk][0] = total;
        part[chunk][1] = beam_total;
    }
    double total = 0.0;
    *beam = 0.0;
    for (int chunk = 0; chunk < POP_SEED_CHUNKS; ++chunk) {
        total += part[chunk][0];
        *beam += part[chunk][1];
    }
    const vdbs_pop_absorption absorption = {sigma, albedo, 0.0};
    vdbs_pop_start_lobes(state, vdbs_radial_cells(f), g, r->desc.tally_cell, f, &absorption);
    return total;
}

/* A point light (Sec. 6): its octahedral radial grid around the light, seeded from the fine
 * S1 grid, propagated with the shared gather, then splatted part by part into the merged grid
 * (fluence times volume is kept; cells of vacuum merge nothing, as on directional grids) and its
 * light still in transit into the isotropic one (power is kept: the iso grid's L is power times
 * h / V). */
static vdbs_status propagate_point(pop_run *r, int l, double mean_sigma_s, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    const vdbs_direct_light *dl = &r->lights.direct[l];
    double r_in, r_out;
    vdbs_volume_support_distances(s->volume, dl->world, &r_in, &r_out);
    r_out *= 1.0 + 1e-6;
    double t0 = vdbs_now();
    vdbs_radial_frame f;
    vdbs_status st = vdbs_radial_octahedral(dl->world, r->desc.radial, r->desc.radial, r_in,
                                            fmax(r_out, r_in * (1.0 + 1e-6) + 1e-9), &f, err);
    if (st != VDBS_OK)
        return st;
    const int64_t cells = vdbs_radial_cells(&f);
    size_t words = 0;
    uint32_t *params =
        vdbs_pop_radial_params(&f, s->scene->g, s->scene->albedo, &r->transport, &words);
    float *state = calloc((size_t)cells * VS_POP_STATE_WORDS, sizeof *state);
    float *sigma = malloc(sizeof *sigma * (size_t)cells);
    if (!params || !state || !sigma) {
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a radial POP grid");
        goto done;
    }
    r->stats->radial_grids += 1;
    r->stats->cells += cells;
    vdbs_radial_sigma(&f, s->volume, &r->box, s->scene->density_scale, r->merged.h, sigma);
    double beam = 0.0;
    const double seeded = seed_radial(r, l, &f, r_out, sigma, state, &beam);
    /* Part 1's energy unit, power times the directional cell side (pop.h). */
    r->stats->seeded += seeded * r->h;
    r->stats->beam_loss += beam * r->h;
    double t1 = vdbs_now();
    r->stats->seconds_seed += t1 - t0;
    /* Eq. 10 with one crossing of the shells at least, then the isotropic residuum, as for
     * directional grids. Running the radial grid on to epsilon_L instead put 3 to 50 times the
     * reference's ms on the Fig. 10 sphere (measured): isotropic light walks the lattice one
     * cell per iteration, and a lattice of step h diffuses like a medium of sigma_tr about
     * 2 / h, far too thick in the small shells near the light. */
    if (seeded > 0.0)
        st = propagate_counted(
            r, params, words, sigma, cells, state,
            anisotropic_iterations(r, f.n[2], r_out / f.n[2], s->scene->g, mean_sigma_s),
            r->desc.epsilon_l * seeded, err);
    double t2 = vdbs_now();
    if (st != VDBS_OK)
        goto done;
    const double merged_volume = r->merged.h * r->merged.h * r->merged.h;
    const double iso_scale = r->iso.h / (r->iso.h * r->iso.h * r->iso.h), g = s->scene->g;
    const int64_t texels = (int64_t)f.n[0] * f.n[1];
    for (int64_t c = 0; c < cells; ++c) {
        const float *cell = state + c * VS_POP_STATE_WORDS;
        int any = 0;
        for (int ch = 0; ch < 3; ++ch)
            any |= cell[VS_POP_STATE_ACC_L + ch] != 0.0f || cell[VS_POP_STATE_L + ch] != 0.0f;
        if (!any)
            continue;
        const double *d = f.dir + 3 * (c % texels);
        double v[VDBS_COARSE_WIDTH], residual[3];
        for (int ch = 0; ch < 3; ++ch) {
            v[VDBS_COARSE_MS + ch] = cell[VS_POP_STATE_ACC_L + ch] * VDBS_INV_4PI;
            for (int a = 0; a < 3; ++a)
                v[VDBS_COARSE_L1 + 3 * a + ch] =
                    3.0 * g * cell[VS_POP_STATE_ACC_LA + ch] * d[a] * VDBS_INV_4PI;
            residual[ch] = cell[VS_POP_STATE_L + ch];
        }
        const double volume = vdbs_radial_cell_volume(&f, c), area = vdbs_radial_cell_area(&f, c);
        double w[3 * VDBS_RADIAL_MAX_PARTS], pv[VDBS_RADIAL_MAX_PARTS];
        int parts = vdbs_radial_cell_parts(&f, c, r->merged.h, w, pv);
        for (int p = 0; p < parts; ++p) {
            /* Parts beyond the support box hold no voxel (their light has left). */
            if (!vdbs_volume_in_support(s->volume, w + 3 * p))
                continue;
            if (sigma[c] > 0.0f &&
                vdbs_coarse_splat_masked(&r->merged, r->merged_acc, VDBS_COARSE_WIDTH, w + 3 * p, v,
                                         pv[p] / merged_volume, r->merged_sigma))
                for (int ch = 0; ch < 3; ++ch)
                    r->stats->merge_in += cell[VS_POP_STATE_ACC_L + ch] * pv[p];
            if (residual[0] != 0.0 || residual[1] != 0.0 || residual[2] != 0.0)
                vdbs_coarse_splat(&r->iso, r->iso_residual, 3, w + 3 * p, residual,
                                  area * pv[p] / volume * iso_scale);
        }
    }
    r->stats->seconds_merge += vdbs_now() - t2;
done:
    free(params);
    free(state);
    free(sigma);
    vdbs_radial_free(&f);
    return st;
}

/* The isotropic residuum (Sec. 5.4), on a world-aligned grid with the directional grids' cell
 * side (not the merged grid's half: a lattice walk of step h diffuses like a medium with
 * sigma_tr h near 2, so finer cells spread isotropic light faster; on the POP check
 * scene the half-size grid tripled POP's image error). Its accumulation in the medium's cells is
 * splatted into the merged grid's ms. */
static vdbs_status isotropic(pop_run *r, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    const vdbs_coarse_frame *f = &r->iso;
    const int64_t cells = vdbs_coarse_cells(f);
    double t0 = vdbs_now();
    const double merged_volume = r->merged.h * r->merged.h * r->merged.h;
    for (int64_t c = 0; c < vdbs_coarse_cells(&r->merged); ++c)
        for (int ch = 0; ch < 3; ++ch)
            r->stats->merge_out += 4.0 * VDBS_PI *
                                   r->merged_acc[c * VDBS_COARSE_WIDTH + VDBS_COARSE_MS + ch] *
                                   merged_volume;
    float *state, *sigma;
    vdbs_status st = grid_arrays(r, f, &state, &sigma, err);
    if (st != VDBS_OK)
        return st;
    const double cell_volume = f->h * f->h * f->h;
    double residual = 0.0;
    for (int64_t c = 0; c < cells; ++c)
        for (int ch = 0; ch < 3; ++ch) {
            float v = (float)r->iso_residual[c * 3 + ch];
            state[c * VS_POP_STATE_WORDS + VS_POP_STATE_L + ch] = v;
            residual += v;
        }
    uint32_t params[VS_POP_PARAM_WORDS];
    vdbs_pop_grid_params(f->n, f->h, s->scene->g, s->scene->albedo, &r->transport, 0, params);
    int iterations = 0;
    double left = residual;
    const double tolerance = r->desc.epsilon_l * r->stats->seeded / cell_volume;
    if (vdbs_progress_cancelled(s->progress))
        st = vdbs_error_cancelled(err);
    else if (residual > tolerance) {
        int cap = 8 * (f->n[0] + f->n[1] + f->n[2]);
        st = vdbs_pop_propagate(s->runner, params, VS_POP_PARAM_WORDS, sigma, cells, state, cap,
                                tolerance, &iterations, &left, err);
    }
    r->stats->iterations_isotropic = iterations;
    r->stats->cell_updates += (double)cells * iterations;
    r->stats->residual = r->stats->seeded > 0.0 ? left * cell_volume / r->stats->seeded : 0.0;
    if (st == VDBS_OK) {
        const double scale = pow(f->h / r->merged.h, 3.0);
        for (int64_t c = 0; c < cells; ++c) {
            const float *cell = state + c * VS_POP_STATE_WORDS;
            double v[VDBS_COARSE_WIDTH] = {0};
            for (int ch = 0; ch < 3; ++ch)
                v[VDBS_COARSE_MS + ch] = cell[VS_POP_STATE_ACC_L + ch] * VDBS_INV_4PI;
            if ((v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) || !(sigma[c] > 0.0f))
                continue;
            (void)splat_cell(r, f, c, v, scale);
        }
    }
    r->stats->seconds_isotropic += vdbs_now() - t0;
    free(state);
    free(sigma);
    return st;
}

vdbs_status vdbs_pop_check(const vdbs_pop_desc *desc, const vdbs_scene *scene, vdbs_error *err)
{
    if (desc->radial > 0 && desc->radial % 2 != 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--pop-radial %d: the octahedral map needs an even resolution",
                              desc->radial);
    if (desc->decay == VDBS_POP_DECAY_PAPER && scene->g < 0.0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--pop-decay paper needs g >= 0 (g^(sigma_s t) is undefined for "
                              "g = %g); use --pop-decay mean-cosine",
                              scene->g);
    if (desc->importance && !scene->camera.present)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--pop-importance needs a camera (--camera or camera in --scene)");
    return VDBS_OK;
}

/* desc's defaults from the quality, and the checks that need the scene. */
static vdbs_status resolve_desc(pop_run *r, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    int ords, radial;
    double eps_l;
    vdbs_pop_quality(s->quality ? s->quality->name : NULL, &ords, &eps_l, &radial);
    if (r->desc.ordinates <= 0)
        r->desc.ordinates = ords;
    if (r->desc.radial <= 0)
        r->desc.radial = radial;
    r->stats->radial = r->desc.radial;
    vdbs_status st = vdbs_pop_check(&r->desc, s->scene, err);
    if (st != VDBS_OK)
        return st;
    if (!(r->desc.epsilon_a > 0.0))
        r->desc.epsilon_a = POP_DEFAULT_EPSILON_A;
    if (!(r->desc.epsilon_l > 0.0))
        r->desc.epsilon_l = eps_l;
    if (r->desc.resolution <= 0)
        r->desc.resolution = POP_DEFAULT_RESOLUTION;
    if (r->desc.max_iterations <= 0)
        r->desc.max_iterations = r->desc.resolution < 16 ? 64 : 4 * r->desc.resolution;
    r->stats->resolution = r->desc.resolution;
    return VDBS_OK;
}

/* The directional grids' cell side, the merged and isotropic grids, the box-filtered medium. */
static vdbs_status setup_grids(pop_run *r, int points, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    double corners[8][3];
    vdbs_volume_support_corners(s->volume, corners);
    const double extent = vdbs_volume_support_extent(s->volume);
    const double h = extent / r->desc.resolution;
    r->stats->cell_side = h;
    r->h = h;
    const double world_axes[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    /* Point lights' radial grids resolve the light's fall-off finer than the directional
     * grids' cells: the merged grid then has as many cells across as a radial grid has shells. */
    double merged_side = 0.5 * h;
    if (points > 0)
        merged_side = fmin(merged_side, extent / r->desc.radial);
    vdbs_coarse_fit(corners, world_axes, merged_side, &r->merged);
    vdbs_coarse_fit(corners, world_axes, h, &r->iso);
    r->stats->merged_cells = vdbs_coarse_cells(&r->merged);
    int block = (int)floor(merged_side / s->volume->mean_voxel_size);
    r->merged_acc =
        calloc((size_t)r->stats->merged_cells * VDBS_COARSE_WIDTH, sizeof *r->merged_acc);
    r->merged_sigma = malloc(sizeof *r->merged_sigma * (size_t)r->stats->merged_cells);
    r->iso_residual = calloc((size_t)vdbs_coarse_cells(&r->iso) * 3, sizeof *r->iso_residual);
    if (!r->merged_acc || !r->merged_sigma || !r->iso_residual)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the merged POP grid");
    vdbs_status st = vdbs_medium_box_build(s->volume, block < 1 ? 1 : block, &r->box, err);
    if (st == VDBS_OK)
        vdbs_coarse_sigma(&r->merged, s->volume, &r->box, s->scene->density_scale, r->merged_sigma);
    return st;
}

/* The suns, points and sky ordinates: from the sky, or the sky times the camera's importance
 * (Sec. 5.2). */
static vdbs_status build_lights(pop_run *r, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    vdbs_status st = VDBS_OK;
    vdbs_envmap importance = {0};
    vdbs_lights_desc ld = {0};
    ld.sky_ordinates = r->desc.ordinates;
    /* A map's small bright sun is one ordinate: drawn by luminance, 5 of 8 ordinates landed on
     * the bundled sky's 3-degree sun, the same grid five times (bench/pop_point.md). */
    ld.split_sun = 1;
    /* Only a map's ordinates are sampled; a constant sky keeps its even directions. */
    if (r->desc.importance && s->scene->env_paths[0] != '\0') {
        vdbs_importance_stats is;
        st = vdbs_importance_map(s->runner, s->volume, s->scene, &r->box, &importance, &is, err);
        ld.importance = &importance;
        r->stats->importance = 1;
        r->stats->importance_cells = is.cells;
        r->stats->importance_iterations = is.iterations;
        r->stats->seconds_importance = is.seconds_propagate + is.seconds_project;
    }
    if (st == VDBS_OK)
        st = vdbs_lights_build(s->volume, s->scene, &ld, &r->lights, err);
    vdbs_envmap_free(&importance);
    return st;
}

/* Every light's grid: a radial grid per point, a directional grid per sun and ordinate. */
static vdbs_status propagate_lights(pop_run *r, int count, double sigma_s, vdbs_error *err)
{
    const double g = r->s->scene->g;
    vdbs_status st = VDBS_OK;
    for (int l = 0; l < count && st == VDBS_OK; ++l) {
        double d[3], e[3], a0;
        if (l < r->lights.direct_count && r->lights.direct[l].type == VDBS_LIGHT_POINT) {
            st = propagate_point(r, l, sigma_s, err);
            continue;
        }
        if (l < r->lights.direct_count) {
            const vdbs_direct_light *dl = &r->lights.direct[l];
            memcpy(d, dl->world, sizeof d);
            memcpy(e, dl->color, sizeof e);
            a0 = g; /* a delta beam scattered once: HG(g) about d */
        } else {
            /* A sky ordinate stands for a patch of solid angle w: as a cap, its light's mean
             * cosine about the ordinate is (1 + cos theta) / 2 with 2 pi (1 - cos theta) = w,
             * and one scattering multiplies it by g (the prefiltered initial anisotropy). */
            const vdbs_sky_ordinate *o = &r->lights.ordinates[l - r->lights.direct_count];
            for (int k = 0; k < 3; ++k) {
                d[k] = -o->world[k];
                e[k] = o->radiance[k] * o->weight;
            }
            double cos_theta = fmax(-1.0, 1.0 - o->weight / (2.0 * VDBS_PI));
            a0 = g * 0.5 * (1.0 + cos_theta);
        }
        st = propagate_grid(r, l, d, e, a0, sigma_s, err);
    }
    return st;
}

vdbs_status vdbs_pop_solve(const vdbs_solve *s, const vdbs_pop_desc *desc, vdbs_pop_stats *stats,
                           vdbs_error *err)
{
    memset(stats, 0, sizeof *stats);
    pop_run r;
    memset(&r, 0, sizeof r);
    r.s = s;
    r.stats = stats;
    r.desc = desc ? *desc : (vdbs_pop_desc){0};
    r.transport = (vdbs_pop_transport){r.desc.decay, r.desc.tally_cell};
    vdbs_status st = resolve_desc(&r, err);
    if (st != VDBS_OK)
        return st;
    int points = 0;
    for (int i = 0; i < s->scene->light_count; ++i)
        points += s->scene->lights[i].type == VDBS_LIGHT_POINT;
    const double sigma_t = s->scene->density_scale * vdbs_medium_mean_density(s->volume);
    const double albedo = (s->scene->albedo[0] + s->scene->albedo[1] + s->scene->albedo[2]) / 3.0;
    vdbs_light_grid_desc fine_desc = {0};
    if (s->s1_grids)
        fine_desc = *s->s1_grids;
    /* The propagation starts from these sweeps: the sky keeps the suns' spacing (the sizing
     * by share was measured for S1 alone). */
    fine_desc.sky_spacing = -1.0;
    st = setup_grids(&r, points, err);
    if (st == VDBS_OK)
        st = build_lights(&r, err);
    if (st != VDBS_OK) {
        run_free(&r);
        return st;
    }
    const int count = r.lights.direct_count + r.lights.ordinate_count;
    stats->grids = count - points;
    double t_sweep = vdbs_now();
    st = vdbs_light_grids_build(s->runner, s->volume, s->scene, &r.lights, 0, count, &fine_desc,
                                &r.fine, err);
    stats->seconds_sweep = vdbs_now() - t_sweep;
    if (st == VDBS_OK)
        st = propagate_lights(&r, count, sigma_t * albedo, err);
    if (st == VDBS_OK)
        st = isotropic(&r, err);
    if (st == VDBS_OK) {
        double t0 = vdbs_now();
        /* The smoothing B-spline: measured closer to the reference than the interpolating
         * one on the merged grid's splats (docs/design.md "Upsampling without seams"). */
        st = vdbs_coarse_upsample(&r.merged, r.merged_acc, s->volume, &r.box,
                                  s->scene->density_scale, VDBS_COARSE_BSPLINE, s->ms, s->ms_l1,
                                  s->radiance, err);
        stats->seconds_upsample = vdbs_now() - t0;
    }
    run_free(&r);
    return st;
}
