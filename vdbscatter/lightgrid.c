#include "vdbscatter/lightgrid.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

/* Beyond this many samples a grid is refused (about 16 GiB of depth at full density). */
#define MAX_SAMPLES ((int64_t)1 << 32)

void vdbs_dir_grid_free(vdbs_dir_grid *grid)
{
    if (!grid)
        return;
    free(grid->column);
    free(grid->depth);
    memset(grid, 0, sizeof *grid);
}

/* An orthonormal frame around unit w (Duff et al. 2017, continuous everywhere). */
static void frame(const double w[3], double u[3], double v[3])
{
    double sign = copysign(1.0, w[2]);
    double a = -1.0 / (sign + w[2]);
    double b = w[0] * w[1] * a;
    u[0] = 1.0 + sign * w[0] * w[0] * a;
    u[1] = sign * b;
    u[2] = -sign * w[0];
    v[0] = b;
    v[1] = sign + w[1] * w[1] * a;
    v[2] = -w[1];
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The smallest world length of the three index axes. */
static double min_voxel_length(const vdbs_volume *volume)
{
    double best = HUGE_VAL;
    for (int a = 0; a < 3; ++a) {
        const double(*m)[4] = volume->index_to_world;
        best = fmin(best, sqrt(m[0][a] * m[0][a] + m[1][a] * m[1][a] + m[2][a] * m[2][a]));
    }
    return best;
}

/* One column: the depth at each sample from the column's start, by one march along the
 * column that stops at every sample (vs_march_advance). Returns whether any density was
 * met. */
static int sweep_column(pnanovdb_buf_t buf, pnanovdb_readaccessor_t *acc, const double start[3],
                        int samples, float h, pnanovdb_vec3_t dir, pnanovdb_vec3_t box_lo,
                        pnanovdb_vec3_t box_hi, float density_scale, float *out)
{
    pnanovdb_vec3_t o = vs_vec3((float)start[0], (float)start[1], (float)start[2]);
    vs_march_state m =
        vs_march_begin(o, dir, h * (float)(samples - 1), box_lo, box_hi, density_scale);
    out[0] = 0.0f;
    for (int k = 1; k < samples; ++k) {
        vs_march_advance(buf, acc, &m, h * (float)k);
        /* Past VS_TAU_LIMIT the march stops: the transmittance is 0 in float from there. */
        out[k] = vs_accum_value(m.tau);
    }
    return out[samples - 1] > 0.0f;
}

vdbs_status vdbs_dir_grid_build(const vdbs_volume *volume, double density_scale,
                                const double travel[3], const vdbs_dir_grid_desc *desc,
                                vdbs_dir_grid *g, vdbs_error *err)
{
    memset(g, 0, sizeof *g);
    double len = sqrt(dot3(travel, travel));
    if (!(len > 0.0) || !isfinite(len))
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "light grid: zero direction");
    double *u = g->axes[0], *v = g->axes[1], *w = g->axes[2];
    for (int a = 0; a < 3; ++a)
        w[a] = travel[a] / len;
    frame(w, u, v);
    int oversample =
        desc && desc->oversample > 0 ? desc->oversample : VDBS_DIR_GRID_DEFAULT_OVERSAMPLE;
    g->h = min_voxel_length(volume) / oversample;

    /* The support box's corners in the frame, relative to its lowest corner (a voxel centre),
     * so that aligned samples fall on voxel centres. */
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    double corner_lo[3] = {lo[0], lo[1], lo[2]}, base[3];
    vdbs_volume_world_point(volume, corner_lo, base);
    double cmin[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, cmax[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int corner = 0; corner < 8; ++corner) {
        double idx[3] = {corner & 1 ? hi[0] : lo[0], corner & 2 ? hi[1] : lo[1],
                         corner & 4 ? hi[2] : lo[2]};
        double p[3], d[3];
        vdbs_volume_world_point(volume, idx, p);
        for (int a = 0; a < 3; ++a)
            d[a] = p[a] - base[a];
        for (int a = 0; a < 3; ++a) {
            double c = dot3(d, g->axes[a]) / g->h;
            cmin[a] = fmin(cmin[a], c);
            cmax[a] = fmax(cmax[a], c);
        }
    }
    /* Round outwards, with a hair of slack so that corners on a sample stay on it. */
    double first[3];
    for (int a = 0; a < 3; ++a) {
        first[a] = floor(cmin[a] + 1e-9);
        double last = ceil(cmax[a] - 1e-9);
        double count = last - first[a] + 1.0;
        if (count > 1e9)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "light grid: %g samples along an axis",
                                  count);
        g->n[a] = (int)count;
    }
    for (int a = 0; a < 3; ++a)
        g->origin[a] =
            base[a] + first[0] * g->h * u[a] + first[1] * g->h * v[a] + first[2] * g->h * w[a];
    int64_t columns = (int64_t)g->n[0] * g->n[1];
    if (columns * g->n[2] > MAX_SAMPLES)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "light grid of %dx%dx%d samples is too large; lower the oversample",
                              g->n[0], g->n[1], g->n[2]);
    g->column = malloc(sizeof *g->column * (size_t)columns);
    /* Rows (one v each) are swept in parallel into their own buffers, then packed. */
    float **rows = calloc((size_t)g->n[1], sizeof *rows);
    int *row_count = calloc((size_t)g->n[1], sizeof *row_count);
    if (!g->column || !rows || !row_count) {
        free(rows);
        free(row_count);
        vdbs_dir_grid_free(g);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    }

    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    double to_index_u[3], to_index_v[3], origin_index[3];
    double u_world[3] = {u[0] * g->h, u[1] * g->h, u[2] * g->h};
    double v_world[3] = {v[0] * g->h, v[1] * g->h, v[2] * g->h};
    vdbs_volume_index_vector(volume, u_world, to_index_u);
    vdbs_volume_index_vector(volume, v_world, to_index_v);
    vdbs_volume_index_point(volume, g->origin, origin_index);
    double dir_index[3];
    vdbs_volume_index_vector(volume, w, dir_index);
    const pnanovdb_vec3_t dir =
        vs_vec3((float)dir_index[0], (float)dir_index[1], (float)dir_index[2]);
    const pnanovdb_vec3_t box_lo = vs_vec3(lo[0], lo[1], lo[2]);
    const pnanovdb_vec3_t box_hi = vs_vec3(hi[0], hi[1], hi[2]);
    const int nu = g->n[0], nv = g->n[1], nw = g->n[2];
    int failed = 0;

#pragma omp parallel
    {
        pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
        float *scratch = malloc(sizeof *scratch * (size_t)nw);
#pragma omp for schedule(dynamic, 1)
        for (int j = 0; j < nv; ++j) {
            float *row = NULL;
            int stored = 0, capacity = 0;
            for (int i = 0; i < nu && scratch; ++i) {
                double start[3];
                for (int a = 0; a < 3; ++a)
                    start[a] = origin_index[a] + i * to_index_u[a] + j * to_index_v[a];
                int64_t *slot = &g->column[(int64_t)j * nu + i];
                *slot = -1;
                if (!sweep_column(buf, &acc, start, nw, (float)g->h, dir, box_lo, box_hi,
                                  (float)density_scale, scratch))
                    continue;
                if (stored == capacity) {
                    capacity = capacity ? 2 * capacity : 16;
                    float *grown = realloc(row, sizeof *row * (size_t)capacity * (size_t)nw);
                    if (!grown) {
#pragma omp atomic write
                        failed = 1;
                        break;
                    }
                    row = grown;
                }
                memcpy(row + (size_t)stored * (size_t)nw, scratch, sizeof *scratch * (size_t)nw);
                *slot = stored++; /* row-local for now */
            }
            if (!scratch) {
#pragma omp atomic write
                failed = 1;
            }
            rows[j] = row;
            row_count[j] = stored;
        }
        free(scratch);
    }

    int64_t total = 0;
    for (int j = 0; j < nv; ++j)
        total += row_count[j];
    g->depth = malloc(sizeof *g->depth * (size_t)(total > 0 ? total : 1) * (size_t)nw);
    if (failed || !g->depth) {
        for (int j = 0; j < nv; ++j)
            free(rows[j]);
        free(rows);
        free(row_count);
        vdbs_dir_grid_free(g);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    }
    int64_t at = 0;
    for (int j = 0; j < nv; ++j) {
        if (row_count[j] > 0)
            memcpy(g->depth + at * nw, rows[j], sizeof *g->depth * (size_t)row_count[j] * nw);
        for (int i = 0; i < nu; ++i) {
            int64_t *slot = &g->column[(int64_t)j * nu + i];
            if (*slot >= 0)
                *slot = (at + *slot) * nw;
        }
        at += row_count[j];
        free(rows[j]);
    }
    free(rows);
    free(row_count);
    g->columns_stored = total;
    g->columns_empty = columns - total;
    return VDBS_OK;
}

/* Depth of column (i, j) at fractional sample c (already clamped to [0, n[2] - 1]). */
static double column_depth(const vdbs_dir_grid *g, int i, int j, int k, double f)
{
    int64_t at = g->column[(int64_t)j * g->n[0] + i];
    if (at < 0)
        return 0.0;
    const float *d = g->depth + at;
    return k + 1 < g->n[2] ? d[k] + f * ((double)d[k + 1] - d[k]) : d[k];
}

/* Index and fraction of a coordinate clamped to [0, n - 1]. */
static int split(double x, int n, double *f)
{
    if (!(x > 0.0)) {
        *f = 0.0;
        return 0;
    }
    if (x >= n - 1) {
        *f = 0.0;
        return n - 1;
    }
    int i = (int)x;
    *f = x - i;
    return i;
}

/* Catmull-Rom weights of the samples at -1, 0, 1, 2 for a fraction t. */
static void catmull_rom(double t, double w[4])
{
    double t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2.0 * t2 - t);
    w[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0);
    w[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
}

static int clampi(int i, int n)
{
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

double vdbs_dir_grid_depth(const vdbs_dir_grid *g, const double world[3])
{
    double d[3] = {world[0] - g->origin[0], world[1] - g->origin[1], world[2] - g->origin[2]};
    double fu, fv, fw;
    int i = split(dot3(d, g->axes[0]) / g->h, g->n[0], &fu);
    int j = split(dot3(d, g->axes[1]) / g->h, g->n[1], &fv);
    int k = split(dot3(d, g->axes[2]) / g->h, g->n[2], &fw);
    double wu[4], wv[4];
    catmull_rom(fu, wu);
    catmull_rom(fv, wv);
    double sum = 0.0, lo = HUGE_VAL, hi = -HUGE_VAL;
    for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) {
            double x =
                column_depth(g, clampi(i + a - 1, g->n[0]), clampi(j + b - 1, g->n[1]), k, fw);
            sum += wu[a] * wv[b] * x;
            if (a >= 1 && a <= 2 && b >= 1 && b <= 2) {
                lo = fmin(lo, x);
                hi = fmax(hi, x);
            }
        }
    /* No overshoot beyond the four nearest columns (sharp edges of the medium). */
    return fmin(fmax(sum, lo), hi);
}
