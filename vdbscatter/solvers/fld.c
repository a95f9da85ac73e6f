#include "vdbscatter/fld.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/coarse.h"
#include "vdbscatter/medium.h"
#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_fld.h"

#define FLD_DEFAULT_UPDATES 6
/* CG keeps a recursively updated residual; every so many iterations it is replaced by the
 * true one, b - A x in double, so that the float operator's rounding cannot stall it. */
#define FLD_RESIDUAL_REPLACEMENT 32
/* The final solve also runs until absorbed + leaked power misses the source by at most this
 * (relative): an L2 residual bound alone does not bound the sum of the residual. */
#define FLD_BALANCE 1e-7
/* Solves before the last, whose D changes anyway, stop at this relative residual; the limiter
 * has settled once phi changes by less than FLD_SETTLED between solves. */
#define FLD_EARLY_TOLERANCE 1e-3
#define FLD_SETTLED 1e-2
/* Back-projection passes of a warm start's phi from the voxels into the cells
 * (phi_from_voxels). */
#define FLD_WARM_PASSES 6
/* The multigrid preconditioner's damped Jacobi smoother: its weight (near 6/7, the best for
 * the 7-point Laplacian), sweeps before and after each coarse correction, and sweeps that
 * stand in for a solve on the coarsest grid (at most FLD_COARSEST cells along each axis). */
#define FLD_JACOBI_WEIGHT 0.8
#define FLD_SMOOTH_SWEEPS 2
#define FLD_COARSE_SWEEPS 16
/* Default of vdbs_fld_desc.runner_cells. */
#define FLD_RUNNER_CELLS 4096

void vdbs_fld_quality(const char *quality, vdbs_fld_preset *preset)
{
    static const vdbs_fld_preset presets[] = {
        {1.0, 12, 1e-4}, {1.0, 12, 1e-5}, {1.0, 12, 1e-6}, {1.0, 12, 1e-7}};
    *preset = presets[vdbs_quality_level(quality)];
}

/* ---- the operator through the runner ---- */

typedef struct fld_kernel {
    const uint32_t *params;
    const float *coef;
} fld_kernel;

static double fld_step(void *user, int step, const void *state_in, void *state_out, uint64_t begin,
                       uint64_t end)
{
    (void)step;
    const fld_kernel *k = user;
    const float *x = state_in;
    float *y = state_out;
    double xax = 0.0;
    for (uint64_t cell = begin; cell < end; ++cell) {
        y[cell] = vs_fld_apply(k->params, k->coef, x, (int)cell);
        xax += (double)x[cell] * y[cell];
    }
    return xax;
}

/* y = A x; the parameters and coefficients are kept on the GPU under their ids (0: uploaded
 * for this call), so that a solve uploads them once, not at every application. Without xax
 * no reduction is read back. */
static vdbs_status operator_apply(vdbs_runner *runner, const uint32_t *params, uint64_t params_id,
                                  const float *coef, uint64_t coef_id, int64_t cells,
                                  const float *x, float *y, double *xax, vdbs_error *err)
{
    fld_kernel k = {params, coef};
    memcpy(y, x, sizeof(float) * (size_t)cells);
    vdbs_kernel_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.items = (uint64_t)cells;
    desc.user = &k;
    desc.cpu_step = fld_step;
    desc.shader = "fld_apply.comp";
    desc.inputs[1] = (vdbs_kernel_input){params, sizeof(uint32_t) * VS_FLD_PARAM_WORDS, params_id};
    desc.inputs[2] =
        (vdbs_kernel_input){coef, sizeof(float) * VS_FLD_COEF_WORDS * 3 * (size_t)cells, coef_id};
    desc.state_words = 1;
    desc.state = y;
    desc.max_iterations = 1;
    desc.reduce = xax ? VDBS_REDUCE_SUM : VDBS_REDUCE_NONE;
    vdbs_kernel_result result;
    memset(&result, 0, sizeof result);
    vdbs_status st = vdbs_kernel_iterate(runner, &desc, &result, err);
    if (xax)
        *xax = result.reduction;
    return st;
}

vdbs_status vdbs_fld_operator(vdbs_runner *runner, const uint32_t *params, const float *coef,
                              int64_t cells, const float *x, float *y, double *xax, vdbs_error *err)
{
    return operator_apply(runner, params, 0, coef, 0, cells, x, y, xax, err);
}

/* ---- the discrete system ---- */

/* vs_fld_coef_at with 64-bit cells (the kernel's int indexing holds for any grid the GPU
 * can store). */
static size_t coef_at(int64_t cell, int channel, int k)
{
    return ((size_t)cell * 3 + (size_t)channel) * VS_FLD_COEF_WORDS + (size_t)k;
}

/* One level of the multigrid preconditioner: the operator of the level above aggregated over
 * 2 x 2 x 2 cells (level 0 is the system itself). */
typedef struct fld_level {
    int n[3];
    int64_t cells;
    float *coef;       /* VS_FLD_COEF_WORDS per cell and channel, as the kernel reads them */
    double *diag;      /* 3 per cell: the operator's diagonal (the Jacobi smoother's) */
    double *r, *z, *t; /* one channel's right side, correction and scratch */
    float *xf, *yf;    /* the kernel's float input and output */
    int via_runner;    /* 0: the operator in a host loop (vdbs_fld_desc.runner_cells) */
    uint32_t params[3][VS_FLD_PARAM_WORDS]; /* the kernel's, per channel */
    /* Via the runner: the resident ids of params (per channel, for the solve) and of coef (a
     * new one whenever the coefficients are rebuilt), so that the GPU holds each once. */
    uint64_t params_id[3], coef_id;
} fld_level;

/* Multigrid levels down to a grid of at most FLD_COARSEST cells along every axis. */
#define FLD_MAX_LEVELS 12
#define FLD_COARSEST 4

typedef struct fld_system {
    vdbs_runner *runner;
    const vdbs_fld_grid *grid;
    int64_t cells;
    double d_max; /* cap of D: a medium with sigma_tr = 1 / (the grid's largest extent) */
    double *d;    /* 3 per cell: the diffusion coefficient in use */
    float *coef;  /* VS_FLD_COEF_WORDS per cell and channel (level 0's) */
    double *diag; /* 3 per cell: the operator's diagonal (level 0's) */
    fld_level level[FLD_MAX_LEVELS];
    int levels;
    int64_t runner_cells; /* levels of fewer cells apply the operator on the host */
    const vdbs_cancel *cancel;
} fld_system;

static double sigma_tr(const vdbs_fld_grid *g, int64_t c, int ch)
{
    return (double)g->sigma_t[c] * (1.0 - g->albedo[ch] * g->g);
}

/* The (i, j, k) of cell c of an n[0] x n[1] x n[2] grid, and of the system's. */
static void level_cell_at(const int n[3], int64_t c, int at[3])
{
    at[0] = (int)(c % n[0]);
    at[1] = (int)((c / n[0]) % n[1]);
    at[2] = (int)(c / ((int64_t)n[0] * n[1]));
}

static void cell_at(const vdbs_fld_grid *g, int64_t c, int at[3])
{
    level_cell_at(g->n, c, at);
}

/* grad phi of one channel at cell c by central differences (one-sided at the faces; 0 along
 * an axis one cell thick). */
static void gradient(const vdbs_fld_grid *g, const double *phi, int64_t c, int ch, double grad[3])
{
    const int64_t stride[3] = {1, g->n[0], (int64_t)g->n[0] * g->n[1]};
    int at[3];
    cell_at(g, c, at);
    for (int a = 0; a < 3; ++a) {
        int lo = at[a] > 0, hi = at[a] + 1 < g->n[a];
        double up = phi[3 * (c + (hi ? stride[a] : 0)) + ch];
        double down = phi[3 * (c - (lo ? stride[a] : 0)) + ch];
        grad[a] = lo + hi ? (up - down) / ((lo + hi) * g->h[a]) : 0.0;
    }
}

static double grad_norm(const vdbs_fld_grid *g, const double *phi, int64_t c, int ch)
{
    double d[3];
    gradient(g, phi, c, ch, d);
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

/* D per cell and channel: classic diffusion without phi (or with the limiter off), else the
 * Levermore-Pomraning limiter written so that it stays finite where sigma_tr or phi vanish:
 * with s = sigma_tr phi and G = |grad phi|, lambda(R) / sigma_tr = phi (2 s + G) /
 * (6 s^2 + 3 s G + G^2) (free streaming, phi / G, in empty cells). */
static void update_d(fld_system *sys, const double *phi, int limiter)
{
    const vdbs_fld_grid *g = sys->grid;
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < sys->cells; ++c)
        for (int ch = 0; ch < 3; ++ch) {
            double st = sigma_tr(g, c, ch), d = sys->d_max;
            if (!limiter || !phi) {
                if (st > 0.0)
                    d = 1.0 / (3.0 * st);
            } else {
                double p = phi[3 * c + ch], grad = grad_norm(g, phi, c, ch);
                double s = st * p, den = 6.0 * s * s + 3.0 * s * grad + grad * grad;
                if (p > 0.0 && den > 0.0)
                    d = p * (2.0 * s + grad) / den;
            }
            sys->d[3 * c + ch] = fmin(d, sys->d_max);
        }
}

/* The Jacobi diagonal of every channel of a level, in double from its float coefficients. */
static void level_diag(fld_level *lv)
{
    const int64_t stride[3] = {1, lv->n[0], (int64_t)lv->n[0] * lv->n[1]};
    const int k_axis[3] = {VS_FLD_COEF_X, VS_FLD_COEF_Y, VS_FLD_COEF_Z};
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < lv->cells; ++c) {
        int at[3];
        level_cell_at(lv->n, c, at);
        for (int ch = 0; ch < 3; ++ch) {
            double diag = (double)lv->coef[coef_at(c, ch, VS_FLD_COEF_ABSORB)] +
                          (double)lv->coef[coef_at(c, ch, VS_FLD_COEF_LEAK)];
            for (int a = 0; a < 3; ++a) {
                if (at[a] + 1 < lv->n[a])
                    diag += lv->coef[coef_at(c, ch, k_axis[a])];
                if (at[a] > 0)
                    diag += lv->coef[coef_at(c - stride[a], ch, k_axis[a])];
            }
            lv->diag[3 * c + ch] = diag;
        }
    }
}

/* Allocates the levels below the system's own (level 0 shares its coefficients): each halves
 * the cells along every axis (rounding up) until none has more than FLD_COARSEST. */
static int levels_create(fld_system *sys)
{
    const vdbs_fld_grid *g = sys->grid;
    int n[3] = {g->n[0], g->n[1], g->n[2]};
    sys->levels = 0;
    for (int l = 0; l < FLD_MAX_LEVELS; ++l) {
        fld_level *lv = &sys->level[l];
        memcpy(lv->n, n, sizeof n);
        lv->cells = (int64_t)n[0] * n[1] * n[2];
        lv->via_runner = lv->cells >= sys->runner_cells;
        for (int ch = 0; ch < 3; ++ch) {
            for (int a = 0; a < 3; ++a)
                lv->params[ch][VS_FLD_OFF_N + a] = (uint32_t)n[a];
            lv->params[ch][VS_FLD_OFF_CHANNEL] = (uint32_t)ch;
            lv->params_id[ch] = lv->via_runner ? vdbs_runner_resident_id(sys->runner) : 0;
        }
        const size_t cells = (size_t)lv->cells;
        if (l == 0) {
            lv->coef = sys->coef;
            lv->diag = sys->diag;
        } else {
            lv->coef = malloc(sizeof *lv->coef * cells * 3 * VS_FLD_COEF_WORDS);
            lv->diag = malloc(sizeof *lv->diag * cells * 3);
        }
        lv->r = malloc(sizeof *lv->r * cells);
        lv->z = malloc(sizeof *lv->z * cells);
        lv->t = malloc(sizeof *lv->t * cells);
        lv->xf = malloc(sizeof *lv->xf * cells);
        lv->yf = malloc(sizeof *lv->yf * cells);
        sys->levels = l + 1;
        if (!lv->coef || !lv->diag || !lv->r || !lv->z || !lv->t || !lv->xf || !lv->yf)
            return 0;
        if (n[0] <= FLD_COARSEST && n[1] <= FLD_COARSEST && n[2] <= FLD_COARSEST)
            break;
        for (int a = 0; a < 3; ++a)
            n[a] = (n[a] + 1) / 2;
    }
    return 1;
}

static void levels_free(fld_system *sys)
{
    for (int l = 0; l < sys->levels; ++l) {
        fld_level *lv = &sys->level[l];
        for (int ch = 0; ch < 3; ++ch)
            vdbs_runner_release(sys->runner, lv->params_id[ch]);
        vdbs_runner_release(sys->runner, lv->coef_id);
        if (l > 0) {
            free(lv->coef);
            free(lv->diag);
        }
        free(lv->r);
        free(lv->z);
        free(lv->t);
        free(lv->xf);
        free(lv->yf);
    }
    sys->levels = 0;
}

/* Each coarse level from the one above: absorption and leak summed over the 8 children (the
 * Galerkin operator of piecewise-constant prolongation), couplings summed over the faces
 * between two parents and halved (Galerkin's sum is twice the rediscretised coupling of a
 * cell twice as wide, which would make the coarse correction half of what it should be). */
static void levels_build(fld_system *sys)
{
    const int k_axis[3] = {VS_FLD_COEF_X, VS_FLD_COEF_Y, VS_FLD_COEF_Z};
    for (int l = 1; l < sys->levels; ++l) {
        const fld_level *f = &sys->level[l - 1];
        fld_level *lv = &sys->level[l];
        const int64_t fstride[3] = {1, f->n[0], (int64_t)f->n[0] * f->n[1]};
#pragma omp parallel for schedule(static)
        for (int64_t c = 0; c < lv->cells; ++c) {
            int at[3];
            level_cell_at(lv->n, c, at);
            double sum[3][VS_FLD_COEF_WORDS] = {{0.0}};
            for (int child = 0; child < 8; ++child) {
                int fa[3];
                int inside = 1;
                for (int a = 0; a < 3; ++a) {
                    fa[a] = 2 * at[a] + ((child >> a) & 1);
                    inside = inside && fa[a] < f->n[a];
                }
                if (!inside)
                    continue;
                const int64_t fc = fa[0] * fstride[0] + fa[1] * fstride[1] + fa[2] * fstride[2];
                for (int ch = 0; ch < 3; ++ch) {
                    sum[ch][VS_FLD_COEF_ABSORB] += f->coef[coef_at(fc, ch, VS_FLD_COEF_ABSORB)];
                    sum[ch][VS_FLD_COEF_LEAK] += f->coef[coef_at(fc, ch, VS_FLD_COEF_LEAK)];
                    for (int a = 0; a < 3; ++a)
                        if (((child >> a) & 1) && at[a] + 1 < lv->n[a])
                            sum[ch][k_axis[a]] += 0.5 * f->coef[coef_at(fc, ch, k_axis[a])];
                }
            }
            for (int ch = 0; ch < 3; ++ch)
                for (int k = 0; k < VS_FLD_COEF_WORDS; ++k)
                    lv->coef[coef_at(c, ch, k)] = (float)sum[ch][k];
        }
        level_diag(lv);
    }
}

/* After the coefficients changed: every runner level's GPU copy is stale, so it gets a new
 * id (uploaded at its first application). */
static void levels_renew(fld_system *sys)
{
    for (int l = 0; l < sys->levels; ++l) {
        fld_level *lv = &sys->level[l];
        vdbs_runner_release(sys->runner, lv->coef_id);
        lv->coef_id = lv->via_runner ? vdbs_runner_resident_id(sys->runner) : 0;
    }
}

/* The coefficients of every channel from D: couplings along axis a by the harmonic mean of the
 * two cells' D over h_a^2 (face area over volume times distance); a boundary face leaks
 * phi 2 D / (h_a + 4 D) per area (Marshak: no light enters), area over volume 1 / h_a.
 * Also the smoother's diagonal of the first level (double, from the float coefficients). */
static void build_coef(fld_system *sys)
{
    const vdbs_fld_grid *g = sys->grid;
    const int64_t stride[3] = {1, g->n[0], (int64_t)g->n[0] * g->n[1]};
    const int k_axis[3] = {VS_FLD_COEF_X, VS_FLD_COEF_Y, VS_FLD_COEF_Z};
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < sys->cells; ++c) {
        int at[3];
        cell_at(g, c, at);
        for (int ch = 0; ch < 3; ++ch) {
            double di = sys->d[3 * c + ch], leak = 0.0;
            for (int a = 0; a < 3; ++a) {
                const double h = g->h[a];
                double up = 0.0;
                if (at[a] + 1 < g->n[a]) {
                    double dj = sys->d[3 * (c + stride[a]) + ch];
                    up = di + dj > 0.0 ? 2.0 * di * dj / (di + dj) / (h * h) : 0.0;
                } else {
                    leak += 2.0 * di / ((h + 4.0 * di) * h);
                }
                if (at[a] == 0)
                    leak += 2.0 * di / ((h + 4.0 * di) * h);
                sys->coef[coef_at(c, ch, k_axis[a])] = (float)up;
            }
            sys->coef[coef_at(c, ch, VS_FLD_COEF_ABSORB)] =
                (float)((double)g->sigma_t[c] * (1.0 - g->albedo[ch]));
            sys->coef[coef_at(c, ch, VS_FLD_COEF_LEAK)] = (float)leak;
        }
    }
    level_diag(&sys->level[0]);
}

/* r = b - A x for one channel in double from the float coefficients: the true residual that
 * CG's recursive one is replaced by, and that the energy tallies rest on. */
static double true_residual(const fld_system *sys, int ch, const double *b, const double *x,
                            double *r, double *sum)
{
    const vdbs_fld_grid *g = sys->grid;
    const int64_t stride[3] = {1, g->n[0], (int64_t)g->n[0] * g->n[1]};
    const int k_axis[3] = {VS_FLD_COEF_X, VS_FLD_COEF_Y, VS_FLD_COEF_Z};
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < sys->cells; ++c) {
        int at[3];
        cell_at(g, c, at);
        double y = ((double)sys->coef[coef_at(c, ch, VS_FLD_COEF_ABSORB)] +
                    (double)sys->coef[coef_at(c, ch, VS_FLD_COEF_LEAK)]) *
                   x[c];
        for (int a = 0; a < 3; ++a) {
            if (at[a] + 1 < g->n[a])
                y += (double)sys->coef[coef_at(c, ch, k_axis[a])] * (x[c] - x[c + stride[a]]);
            if (at[a] > 0)
                y += (double)sys->coef[coef_at(c - stride[a], ch, k_axis[a])] *
                     (x[c] - x[c - stride[a]]);
        }
        r[c] = b[c] - y;
    }
    /* Summed in cell order, not by an OpenMP reduction (whose order follows the thread count):
     * the sums decide when CG stops, and so the bits of phi. */
    double norm = 0.0, total = 0.0;
    for (int64_t c = 0; c < sys->cells; ++c) {
        norm += r[c] * r[c];
        total += r[c];
    }
    *sum = total;
    return sqrt(norm);
}

/* The right side of one channel: Q - div(3 D M). A face's source flux is 3 D_face times the
 * two cells' mean M (D_face the coupling's harmonic mean, coupling h^2); a boundary face
 * carries h/(h + 4 D) of the cell's 3 D M out with Marshak's condition (its outward share
 * is returned per volume in *boundary, summed, so that it counts as leaked). With an inward
 * current J on a boundary face, Marshak's condition between the face and the cell centre
 * (half a cell) lets in 8 D J / (h + 4 D) beside the leak 2 D phi / (h + 4 D): a uniform
 * phi = 4 J with nothing absorbed is then exact (returned per volume in *inflow). */
static void source_rhs(const fld_system *sys, int ch, double *b, double *boundary, double *inflow)
{
    const vdbs_fld_grid *g = sys->grid;
    const int64_t stride[3] = {1, g->n[0], (int64_t)g->n[0] * g->n[1]};
    const int k_axis[3] = {VS_FLD_COEF_X, VS_FLD_COEF_Y, VS_FLD_COEF_Z};
    double out = 0.0, in = 0.0;
    for (int64_t c = 0; c < sys->cells; ++c)
        b[c] = g->source[3 * c + ch];
    for (int64_t c = 0; g->inflow && c < sys->cells; ++c) {
        int at[3];
        cell_at(g, c, at);
        const double d = sys->d[3 * c + ch];
        for (int a = 0; a < 3; ++a)
            for (int side = 0; side < 2; ++side) {
                if (at[a] != (side ? g->n[a] - 1 : 0))
                    continue;
                const double h = g->h[a];
                const double q = 8.0 * d * g->inflow[3 * (2 * a + side) + ch] / ((h + 4.0 * d) * h);
                b[c] += q;
                in += q;
            }
    }
    *inflow = in;
    for (int64_t c = 0; g->moment && c < sys->cells; ++c) {
        int at[3];
        cell_at(g, c, at);
        const double d = sys->d[3 * c + ch];
        for (int a = 0; a < 3; ++a) {
            const double h = g->h[a];
            const double m = g->moment[9 * c + 3 * a + ch];
            if (at[a] + 1 < g->n[a]) {
                const double d_face = (double)sys->coef[coef_at(c, ch, k_axis[a])] * h * h;
                const double s =
                    3.0 * d_face * 0.5 * (m + g->moment[9 * (c + stride[a]) + 3 * a + ch]) / h;
                b[c] -= s;
                b[c + stride[a]] += s;
            } else {
                const double s = 3.0 * d * m / (h + 4.0 * d);
                b[c] -= s;
                out += s;
            }
            if (at[a] == 0) {
                const double s = -3.0 * d * m / (h + 4.0 * d);
                b[c] -= s;
                out += s;
            }
        }
    }
    *boundary = out;
}

/* What the operator applications cost: how many, and the cells they updated. */
typedef struct fld_cost {
    int applications;
    int64_t cells;
} fld_cost;

/* y = A x on one level for one channel, through the runner (float in and out). */
static vdbs_status level_apply(vdbs_runner *runner, fld_level *lv, int ch, const double *x,
                               double *y, fld_cost *cost, vdbs_error *err)
{
    const uint32_t *params = lv->params[ch];
    for (int64_t c = 0; c < lv->cells; ++c)
        lv->xf[c] = (float)x[c];
    vdbs_status st = VDBS_OK;
    if (lv->via_runner)
        st = operator_apply(runner, params, lv->params_id[ch], lv->coef, lv->coef_id, lv->cells,
                            lv->xf, lv->yf, NULL, err);
    else
        for (int64_t c = 0; c < lv->cells; ++c)
            lv->yf[c] = vs_fld_apply(params, lv->coef, lv->xf, (int)c);
    for (int64_t c = 0; c < lv->cells; ++c)
        y[c] = lv->yf[c];
    ++cost->applications;
    cost->cells += lv->cells;
    return st;
}

/* `sweeps` damped Jacobi sweeps z += omega (r - A z) / diag on one level. */
static vdbs_status smooth(vdbs_runner *runner, fld_level *lv, int ch, int sweeps, fld_cost *cost,
                          vdbs_error *err)
{
    vdbs_status st = VDBS_OK;
    for (int s = 0; s < sweeps && st == VDBS_OK; ++s) {
        st = level_apply(runner, lv, ch, lv->z, lv->t, cost, err);
        for (int64_t c = 0; c < lv->cells; ++c) {
            double diag = lv->diag[3 * c + ch];
            if (diag > 0.0)
                lv->z[c] += FLD_JACOBI_WEIGHT * (lv->r[c] - lv->t[c]) / diag;
        }
    }
    return st;
}

/* One V-cycle from z = 0 for level l's right side r into its z: FLD_SMOOTH_SWEEPS Jacobi sweeps
 * before and after the coarse correction (FLD_COARSE_SWEEPS on the coarsest level), the
 * residual summed into the parents, the parents' correction added to their children. Pre-
 * and post-smoothing alike and restriction the transpose of prolongation: a symmetric
 * positive preconditioner, as CG needs. */
static vdbs_status vcycle(vdbs_runner *runner, fld_system *sys, int l, int ch, fld_cost *cost,
                          vdbs_error *err)
{
    fld_level *lv = &sys->level[l];
    const int coarsest = l + 1 == sys->levels;
    /* The first sweep from z = 0 needs no operator. */
    for (int64_t c = 0; c < lv->cells; ++c) {
        double diag = lv->diag[3 * c + ch];
        lv->z[c] = diag > 0.0 ? FLD_JACOBI_WEIGHT * lv->r[c] / diag : 0.0;
    }
    vdbs_status st =
        smooth(runner, lv, ch, (coarsest ? FLD_COARSE_SWEEPS : FLD_SMOOTH_SWEEPS) - 1, cost, err);
    if (st != VDBS_OK || coarsest)
        return st;
    fld_level *coarse = &sys->level[l + 1];
    st = level_apply(runner, lv, ch, lv->z, lv->t, cost, err);
    if (st != VDBS_OK)
        return st;
    memset(coarse->r, 0, sizeof *coarse->r * (size_t)coarse->cells);
    const int64_t cstride[3] = {1, coarse->n[0], (int64_t)coarse->n[0] * coarse->n[1]};
    for (int64_t c = 0; c < lv->cells; ++c) {
        int at[3];
        level_cell_at(lv->n, c, at);
        coarse->r[(at[0] / 2) * cstride[0] + (at[1] / 2) * cstride[1] + (at[2] / 2) * cstride[2]] +=
            lv->r[c] - lv->t[c];
    }
    st = vcycle(runner, sys, l + 1, ch, cost, err);
    if (st != VDBS_OK)
        return st;
    for (int64_t c = 0; c < lv->cells; ++c) {
        int at[3];
        level_cell_at(lv->n, c, at);
        lv->z[c] +=
            coarse
                ->z[(at[0] / 2) * cstride[0] + (at[1] / 2) * cstride[1] + (at[2] / 2) * cstride[2]];
    }
    return smooth(runner, lv, ch, FLD_SMOOTH_SWEEPS, cost, err);
}

/* z = M^-1 r, M the multigrid V-cycle. */
static vdbs_status precondition(vdbs_runner *runner, fld_system *sys, int ch, const double *r,
                                double *z, fld_cost *cost, vdbs_error *err)
{
    fld_level *top = &sys->level[0];
    memcpy(top->r, r, sizeof *r * (size_t)top->cells);
    vdbs_status st = vcycle(runner, sys, 0, ch, cost, err);
    memcpy(z, top->z, sizeof *z * (size_t)top->cells);
    return st;
}

/* Multigrid-preconditioned CG for one channel: x in (first guess) and out, until the true
 * relative residual is at most `tolerance` and, with `balance`, the residual's sum (the power
 * that absorbed + leaked misses, per volume) at most FLD_BALANCE of the source's. Returns the
 * iterations, and adds the operator applications (all levels) to *cost; *relative the final true
 * relative residual. */
static vdbs_status solve_channel(vdbs_runner *runner, fld_system *sys, int ch, const double *b,
                                 double *x, double tolerance, int balance, int max_iterations,
                                 int *iterations, fld_cost *cost, double *relative, vdbs_error *err)
{
    const int64_t n = sys->cells;
    double *r = malloc(sizeof *r * (size_t)n), *z = malloc(sizeof *z * (size_t)n);
    double *p = malloc(sizeof *p * (size_t)n), *ap = malloc(sizeof *ap * (size_t)n);
    vdbs_status st = VDBS_OK;
    if (!r || !z || !p || !ap) {
        st =
            vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for FLD's %lld cells", (long long)n);
        goto done;
    }
    double b_norm = 0.0, b_sum = 0.0;
    for (int64_t c = 0; c < n; ++c) {
        b_norm += b[c] * b[c];
        b_sum += fabs(b[c]);
    }
    b_norm = sqrt(b_norm);
    *iterations = 0;
    *relative = 0.0;
    if (!(b_norm > 0.0)) {
        memset(x, 0, sizeof *x * (size_t)n);
        goto done;
    }
    double rz = 0.0;
    int since_true = FLD_RESIDUAL_REPLACEMENT;
    for (;;) {
        if (vdbs_cancelled(sys->cancel)) {
            st = vdbs_error_cancelled(err);
            break;
        }
        if (since_true >= FLD_RESIDUAL_REPLACEMENT) {
            /* (Re)start from the true residual. */
            double r_sum = 0.0;
            *relative = true_residual(sys, ch, b, x, r, &r_sum) / b_norm;
            int balanced = !balance || fabs(r_sum) <= FLD_BALANCE * b_sum;
            if ((*relative <= tolerance && balanced) || *iterations >= max_iterations)
                break;
            if ((st = precondition(runner, sys, ch, r, z, cost, err)) != VDBS_OK)
                break;
            rz = 0.0;
            for (int64_t c = 0; c < n; ++c) {
                p[c] = z[c];
                rz += r[c] * z[c];
            }
            since_true = 0;
        }
        if ((st = level_apply(runner, &sys->level[0], ch, p, ap, cost, err)) != VDBS_OK)
            break;
        double pap = 0.0;
        for (int64_t c = 0; c < n; ++c)
            pap += p[c] * ap[c];
        ++*iterations;
        ++since_true;
        if (!(pap > 0.0)) {
            since_true = FLD_RESIDUAL_REPLACEMENT; /* lost conjugacy: restart */
            continue;
        }
        double alpha = rz / pap, r_norm = 0.0;
        for (int64_t c = 0; c < n; ++c) {
            x[c] += alpha * p[c];
            r[c] -= alpha * ap[c];
            r_norm += r[c] * r[c];
        }
        /* The recursive residual says done (or the replacement is due): check the true one. */
        if (sqrt(r_norm) <= tolerance * b_norm || *iterations >= max_iterations) {
            since_true = FLD_RESIDUAL_REPLACEMENT;
            continue;
        }
        if ((st = precondition(runner, sys, ch, r, z, cost, err)) != VDBS_OK)
            break;
        double rz_new = 0.0;
        for (int64_t c = 0; c < n; ++c)
            rz_new += r[c] * z[c];
        double beta = rz_new / rz;
        rz = rz_new;
        for (int64_t c = 0; c < n; ++c)
            p[c] = z[c] + beta * p[c];
    }
done:
    free(r);
    free(z);
    free(p);
    free(ap);
    return st;
}

/* The flux at every cell, F = D (3 M - grad phi), shortened where |F| > phi / 3: the
 * longest flux whose P1 radiance (phi + 3 F . w) / 4 pi is nowhere negative. Without the
 * bound the first-moment term made F too long where the light is forward-peaked (g 0.85
 * image error 0.088 -> 0.042 on the sphere, 0.144 -> 0.092 on the cloud, docs/methods/fld.md). */
static void cell_flux(const fld_system *sys, const double *phi, double *flux)
{
    const vdbs_fld_grid *g = sys->grid;
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < sys->cells; ++c)
        for (int ch = 0; ch < 3; ++ch) {
            double grad[3], f[3], len = 0.0;
            gradient(g, phi, c, ch, grad);
            for (int a = 0; a < 3; ++a) {
                const double m = g->moment ? 3.0 * g->moment[9 * c + 3 * a + ch] : 0.0;
                f[a] = sys->d[3 * c + ch] * (m - grad[a]);
                len += f[a] * f[a];
            }
            len = sqrt(len);
            const double bound = fmax(phi[3 * c + ch], 0.0) / 3.0;
            const double scale = len > bound ? bound / len : 1.0;
            for (int a = 0; a < 3; ++a)
                flux[9 * c + 3 * a + ch] = f[a] * scale;
        }
}

/* Energy tallies from phi in double: source, absorbed and leaked power (summed channels);
 * `boundary` is the first-moment source's share through the boundary, `inflow` what the
 * boundary let in, both per volume. */
static void tally(const fld_system *sys, const double *phi, double boundary, double inflow,
                  vdbs_fld_stats *stats)
{
    const vdbs_fld_grid *g = sys->grid;
    const double volume = g->h[0] * g->h[1] * g->h[2];
    double source = inflow * volume, absorbed = 0.0, leaked = boundary * volume;
    for (int64_t c = 0; c < sys->cells; ++c)
        for (int ch = 0; ch < 3; ++ch) {
            source += g->source[3 * c + ch] * volume;
            absorbed +=
                (double)sys->coef[coef_at(c, ch, VS_FLD_COEF_ABSORB)] * phi[3 * c + ch] * volume;
            leaked +=
                (double)sys->coef[coef_at(c, ch, VS_FLD_COEF_LEAK)] * phi[3 * c + ch] * volume;
        }
    stats->source = source;
    stats->absorbed = absorbed;
    stats->leaked = leaked;
}

vdbs_status vdbs_fld_solve_grid(vdbs_runner *runner, const vdbs_fld_grid *grid,
                                const vdbs_fld_desc *desc, double *phi, double *flux,
                                vdbs_fld_stats *stats, vdbs_error *err)
{
    vdbs_fld_stats local;
    if (!stats)
        stats = &local;
    vdbs_fld_desc d = desc ? *desc : (vdbs_fld_desc){0};
    if (d.max_updates <= 0)
        d.max_updates = FLD_DEFAULT_UPDATES;
    if (d.runner_cells <= 0)
        d.runner_cells = FLD_RUNNER_CELLS;
    if (!(d.tolerance > 0.0))
        d.tolerance = 1e-5;
    fld_system sys;
    memset(&sys, 0, sizeof sys);
    sys.runner = runner;
    sys.grid = grid;
    sys.runner_cells = d.runner_cells;
    sys.cancel = d.cancel;
    sys.cells = (int64_t)grid->n[0] * grid->n[1] * grid->n[2];
    double largest = 0.0;
    for (int a = 0; a < 3; ++a)
        largest = fmax(largest, grid->n[a] * grid->h[a]);
    sys.d_max = largest / 3.0;
    stats->cells = sys.cells;
    stats->cell_side = fmax(grid->h[0], fmax(grid->h[1], grid->h[2]));
    const size_t n3 = 3 * (size_t)sys.cells;
    sys.d = malloc(sizeof *sys.d * n3);
    sys.diag = malloc(sizeof *sys.diag * n3);
    sys.coef = malloc(sizeof *sys.coef * n3 * VS_FLD_COEF_WORDS);
    double *b = malloc(sizeof *b * (size_t)sys.cells), *x = malloc(sizeof *x * (size_t)sys.cells);
    vdbs_status st = VDBS_OK;
    if (!sys.d || !sys.diag || !sys.coef || !b || !x || !levels_create(&sys))
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for FLD's %lld cells",
                            (long long)sys.cells);
    stats->levels = sys.levels;
    /* Without a first guess the first solve is classic diffusion; the limiter then needs phi. */
    int have_phi = 0;
    for (size_t v = 0; v < n3 && !have_phi; ++v)
        have_phi = phi[v] != 0.0;
    stats->warm_start = have_phi;
    const int cap = 200 * largest + 200;
    stats->cg_iterations = 0;
    fld_cost cost = {0, 0};
    stats->updates = 0;
    int last = 0;
    double boundary = 0.0, inflow = 0.0;
    for (int u = 0; !last && st == VDBS_OK; ++u) {
        last = d.limiter_off || u + 1 >= d.max_updates;
        update_d(&sys, have_phi ? phi : NULL, !d.limiter_off);
        build_coef(&sys);
        levels_build(&sys);
        levels_renew(&sys);
        const double tolerance = last ? d.tolerance : fmax(d.tolerance, FLD_EARLY_TOLERANCE);
        double worst = 0.0, change = 0.0, norm = 0.0;
        boundary = inflow = 0.0;
        for (int ch = 0; ch < 3 && st == VDBS_OK; ++ch) {
            double out = 0.0, in = 0.0;
            source_rhs(&sys, ch, b, &out, &in);
            boundary += out;
            inflow += in;
            for (int64_t c = 0; c < sys.cells; ++c)
                x[c] = phi[3 * c + ch];
            int iterations = 0;
            double relative = 0.0;
            st = solve_channel(runner, &sys, ch, b, x, tolerance, last, cap, &iterations, &cost,
                               &relative, err);
            stats->cg_iterations += iterations;
            worst = fmax(worst, relative);
            for (int64_t c = 0; c < sys.cells; ++c) {
                double delta = x[c] - phi[3 * c + ch];
                change += delta * delta;
                norm += x[c] * x[c];
                phi[3 * c + ch] = x[c];
            }
        }
        /* Once the limiter has settled, one more solve at the full tolerance ends it. */
        if (have_phi && change <= FLD_SETTLED * FLD_SETTLED * norm)
            d.max_updates = u + 2;
        have_phi = 1;
        stats->updates = u + 1;
        stats->residual = worst;
        stats->operator_applications = cost.applications;
        stats->cell_updates = cost.cells;
    }
    if (st == VDBS_OK) {
        tally(&sys, phi, boundary, inflow, stats);
        if (flux)
            cell_flux(&sys, phi, flux);
    }
    levels_free(&sys);
    free(sys.d);
    free(sys.diag);
    free(sys.coef);
    free(b);
    free(x);
    return st;
}

/* ---- the bake ---- */

/* Q per cell: every voxel's first-scattered power, albedo times its first collisions
 * (averaged over the voxel, collision.h) times its volume, splatted into the cells
 * (trilinear, renormalised: the total is kept) over the cell volume; with the collisions' flux
 * also the first moment g albedo F1 (9 per cell) the same way. */
static void gather_source(const vdbs_solve *s, const vdbs_coarse_frame *f, const double *collisions,
                          const double *collision_flux, double *source, double *moment)
{
    const vdbs_volume *volume = s->volume;
    const double scale = vdbs_volume_voxel_volume(volume) / vdbs_coarse_cell_volume(f);
    for (size_t n = 0; n < volume->coord_count; ++n) {
        const double *c = collisions + 3 * n;
        if (!(c[0] > 0.0 || c[1] > 0.0 || c[2] > 0.0))
            continue;
        double q[12], w[3];
        for (int ch = 0; ch < 3; ++ch) {
            const double albedo = s->scene->albedo[ch];
            q[ch] = albedo * c[ch];
            for (int a = 0; collision_flux && a < 3; ++a)
                q[3 + 3 * a + ch] = s->scene->g * albedo * collision_flux[9 * n + 3 * a + ch];
        }
        vdbs_volume_voxel_point(volume, n, w);
        vdbs_coarse_splat(f, source, 3, w, q, scale);
        if (collision_flux)
            vdbs_coarse_splat(f, moment, 9, w, q + 3, scale);
    }
}

/* --warm-start: the cell values whose trilinear samples at the voxels (phi_to_voxels) give
 * the kept phi there, by back-projection: the residual at each voxel splatted into its cells
 * with the sampling's weights, each cell moved by the weighted mean, FLD_WARM_PASSES times. One
 * pass (the weighted mean of the kept values) smooths phi across the cells: on the cloud sample
 * (low, g 0.85) a warm start from the same volume then saved 6 of 57 CG iterations, six passes
 * 24. Voxels the file had no value for (exactly 0: beyond the frame it was baked for, where
 * phi, positive wherever light reaches, would have one) take no part. Cells that no such voxel
 * weighs (no medium near them, or new since the file) are filled from the weighed ones
 * outwards, each the mean of its face neighbours one step nearer: left at 0, with one pass,
 * the first solve began at a relative residual of 3 (a cold start's is 1), the zeros beside
 * lit cells spoiling the first limiter's gradient. */
static void phi_from_voxels(const vdbs_volume *volume, const vdbs_coarse_frame *f,
                            const float *voxels, double *phi)
{
    const int64_t cells = vdbs_coarse_cells(f);
    double *acc = malloc(sizeof *acc * 4 * (size_t)cells);
    float *guess = calloc(3 * (size_t)cells, sizeof *guess);
    int *layer = malloc(sizeof *layer * (size_t)cells);
    int64_t *queue = malloc(sizeof *queue * (size_t)cells);
    if (!acc || !guess || !layer || !queue) {
        free(acc);
        free(guess);
        free(layer);
        free(queue);
        return; /* a cold start: the solve still converges */
    }
    for (int pass = 0; pass < FLD_WARM_PASSES; ++pass) {
        memset(acc, 0, sizeof *acc * 4 * (size_t)cells);
        for (size_t n = 0; n < volume->coord_count; ++n) {
            const float *v = voxels + 3 * n;
            if (v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f)
                continue;
            double w[3], r[4] = {0.0, 0.0, 0.0, 1.0};
            vdbs_volume_voxel_point(volume, n, w);
            if (pass > 0)
                vdbs_coarse_sample(f, guess, 3, w, r);
            for (int ch = 0; ch < 3; ++ch)
                r[ch] = v[ch] - (pass > 0 ? r[ch] : 0.0);
            vdbs_coarse_splat(f, acc, 4, w, r, 1.0);
        }
        for (int64_t c = 0; c < cells; ++c)
            for (int ch = 0; acc[4 * c + 3] > 0.0 && ch < 3; ++ch) {
                phi[3 * c + ch] += acc[4 * c + ch] / acc[4 * c + 3];
                guess[3 * c + ch] = (float)phi[3 * c + ch];
            }
    }
    /* Breadth first from the weighed cells (layer 0): a cell of layer L takes the mean of its
     * face neighbours of layer L - 1, all done before the first of layer L is taken. */
    int64_t head = 0, tail = 0;
    for (int64_t c = 0; c < cells; ++c) {
        layer[c] = acc[4 * c + 3] > 0.0 ? 0 : -1;
        if (!layer[c])
            queue[tail++] = c;
    }
    const int64_t stride[3] = {1, f->n[0], (int64_t)f->n[0] * f->n[1]};
    while (head < tail) {
        const int64_t c = queue[head++];
        int at[3], count = 0;
        double sum[3] = {0.0, 0.0, 0.0};
        at[0] = (int)(c % f->n[0]);
        at[1] = (int)((c / f->n[0]) % f->n[1]);
        at[2] = (int)(c / stride[2]);
        for (int a = 0; a < 3; ++a)
            for (int side = -1; side <= 1; side += 2) {
                if (at[a] + side < 0 || at[a] + side >= f->n[a])
                    continue;
                const int64_t nb = c + side * stride[a];
                if (layer[nb] < 0) {
                    layer[nb] = layer[c] + 1;
                    queue[tail++] = nb;
                } else if (layer[c] > 0 && layer[nb] == layer[c] - 1) {
                    ++count;
                    for (int ch = 0; ch < 3; ++ch)
                        sum[ch] += phi[3 * nb + ch];
                }
            }
        for (int ch = 0; count && ch < 3; ++ch)
            phi[3 * c + ch] = sum[ch] / count;
    }
    free(acc);
    free(guess);
    free(layer);
    free(queue);
}

/* --keep-state: phi at every output voxel, trilinear from the cells (the transpose of the
 * splat, as the cells of a warm start gather it back). */
static vdbs_status phi_to_voxels(const vdbs_volume *volume, const vdbs_coarse_frame *f,
                                 const double *phi, vdbs_fld_state *keep, vdbs_error *err)
{
    const int64_t cells = vdbs_coarse_cells(f);
    float *cell_phi = malloc(sizeof *cell_phi * 3 * (size_t)cells);
    float *voxels = malloc(sizeof *voxels * 3 * (volume->coord_count ? volume->coord_count : 1));
    if (!cell_phi || !voxels) {
        free(cell_phi);
        free(voxels);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for FLD's kept state");
    }
    for (size_t v = 0; v < 3 * (size_t)cells; ++v)
        cell_phi[v] = (float)phi[v];
    const int64_t count = (int64_t)volume->coord_count;
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        double w[3], p[3];
        vdbs_volume_voxel_point(volume, (size_t)n, w);
        vdbs_coarse_sample(f, cell_phi, 3, w, p);
        for (int ch = 0; ch < 3; ++ch)
            voxels[3 * n + ch] = (float)p[ch];
    }
    free(cell_phi);
    free(keep->phi);
    keep->phi = voxels;
    keep->voxels = volume->coord_count;
    return VDBS_OK;
}

vdbs_status vdbs_fld_solve(const vdbs_solve *s, const vdbs_fld_desc *desc, vdbs_fld_stats *stats,
                           vdbs_error *err)
{
    vdbs_fld_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    vdbs_fld_desc d = desc ? *desc : (vdbs_fld_desc){0};
    if (!d.cancel)
        d.cancel = vdbs_progress_cancel(s->progress);
    vdbs_fld_preset preset;
    vdbs_fld_quality(s->quality ? s->quality->name : NULL, &preset);
    if (!(d.tolerance > 0.0))
        d.tolerance = preset.tolerance;
    const double extent = vdbs_volume_support_extent(s->volume);
    if (d.resolution <= 0) {
        /* From the medium: the preset's cells per mean transport free path across the
         * extent, at least its floor. */
        const double *a = s->scene->albedo;
        stats->mean_sigma_tr = s->scene->density_scale * vdbs_medium_mean_density(s->volume) *
                               (1.0 - (a[0] + a[1] + a[2]) / 3.0 * s->scene->g);
        double across = ceil(extent * stats->mean_sigma_tr * preset.cells_per_path);
        d.resolution = (int)fmin(fmax(across, (double)preset.min_resolution), 1e6);
    }
    vdbs_coarse_frame f;
    d.resolution = vdbs_coarse_world_frame(s->volume, d.resolution,
                                           d.across > 0 ? d.across : VDBS_COARSE_MIN_ACROSS, &f);
    const int64_t cells = vdbs_coarse_cells(&f);
    stats->resolution = d.resolution;
    double t0 = vdbs_now();
    vdbs_medium_box box;
    /* The medium box-filtered at the shortest side: a thin axis keeps its profile. */
    int block =
        (int)floor(fmin(f.side[0], fmin(f.side[1], f.side[2])) / s->volume->mean_voxel_size);
    vdbs_status st = vdbs_medium_box_build(s->volume, block < 1 ? 1 : block, &box, err);
    if (st != VDBS_OK)
        return st;
    float *sigma = malloc(sizeof *sigma * (size_t)cells);
    double *source = calloc(3 * (size_t)cells, sizeof *source);
    double *phi = calloc(3 * (size_t)cells, sizeof *phi);
    double *flux = d.write_l1 ? calloc(9 * (size_t)cells, sizeof *flux) : NULL;
    double *moment = d.collision_flux ? calloc(9 * (size_t)cells, sizeof *moment) : NULL;
    double *values = calloc(VDBS_COARSE_WIDTH * (size_t)cells, sizeof *values);
    if (!sigma || !source || !phi || (d.write_l1 && !flux) || (d.collision_flux && !moment) ||
        !values)
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for FLD's %lld cells",
                            (long long)cells);
    if (st == VDBS_OK) {
        vdbs_coarse_sigma(&f, s->volume, &box, s->scene->density_scale, sigma);
        gather_source(s, &f, d.collisions, d.collision_flux, source, moment);
        if (d.warm && d.warm->phi && d.warm->voxels == s->volume->coord_count)
            phi_from_voxels(s->volume, &f, d.warm->phi, phi);
        /* A uniform radiance L arrives through every face as the current pi L. */
        double inflow[18];
        for (int i = 0; d.sky_floor && i < 18; ++i)
            inflow[i] = VDBS_PI * d.sky_floor->radiance[i % 3];
        stats->seconds_source = vdbs_now() - t0;
        vdbs_fld_grid grid = {{f.n[0], f.n[1], f.n[2]},
                              {f.side[0], f.side[1], f.side[2]},
                              sigma,
                              {s->scene->albedo[0], s->scene->albedo[1], s->scene->albedo[2]},
                              s->scene->g,
                              source,
                              moment,
                              d.sky_floor ? inflow : NULL};
        double t1 = vdbs_now();
        st = vdbs_fld_solve_grid(s->runner, &grid, &d, phi, flux, stats, err);
        stats->seconds_solve = vdbs_now() - t1;
    }
    if (st == VDBS_OK) {
        double t2 = vdbs_now();
        if (d.sky_floor && flux)
            vdbs_sky_floor_take_flux(d.sky_floor, s->volume, &f, flux);
        vdbs_coarse_ms_values(cells, phi, flux, s->scene->g, values);
        /* Through the cell values: the interpolating B-spline (docs/design.md "Upsampling
         * without seams"). */
        st = vdbs_coarse_upsample(&f, values, s->volume, &box, s->scene->density_scale,
                                  VDBS_COARSE_BSPLINE_INTERP, s->ms, s->ms_l1, s->radiance, err);
        if (st == VDBS_OK && d.sky_floor)
            vdbs_sky_floor_remove(d.sky_floor, s->volume->coord_count, s->ms, s->radiance);
        if (st == VDBS_OK && d.keep)
            st = phi_to_voxels(s->volume, &f, phi, d.keep, err);
        stats->seconds_upsample = vdbs_now() - t2;
    }
    vdbs_medium_box_free(&box);
    free(sigma);
    free(source);
    free(phi);
    free(flux);
    free(moment);
    free(values);
    return st;
}
