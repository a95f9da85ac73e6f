#include "vdbscatter/lightgrid.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vdbs_math.h"
#include "vs_common.h"
#include "vs_march.h"

/* Beyond this many samples a grid is refused (16 GiB of depth if every column were stored). */
#define MAX_SAMPLES ((int64_t)1 << 32)
/* Octahedral texels per side at most (a point light far from a huge volume). */
#define MAX_RESOLUTION 4096

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

static int oversample_of(const vdbs_light_grid_desc *desc)
{
    return desc && desc->oversample > 0 ? desc->oversample : VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
}

/* ---- sparse columns, shared by both kinds ---- */

static void columns_free(vdbs_light_columns *c)
{
    free(c->column);
    free(c->depth);
    memset(c, 0, sizeof *c);
}

/* What a column sweep needs: the march of column (i, j) starts at `start` (index space) along
 * `dir` and stops at the sample distances t[k] (world units). */
typedef struct column_sweep {
    const vdbs_volume *volume;
    pnanovdb_buf_t buf;
    pnanovdb_vec3_t box_lo, box_hi;
    float density_scale;
    const float *t; /* n[2] increasing distances, t[0] = 0 */
    /* Fills start and dir for column (i, j); returns 0 for a column known to be empty. */
    int (*ray)(const void *grid, int i, int j, double start[3], double dir[3]);
    const void *grid;
} column_sweep;

/* One column: the depth at each sample, by one march along the column that stops at every
 * sample (vs_march_advance). Returns whether any density was met. */
static int sweep_column(const column_sweep *s, pnanovdb_readaccessor_t *acc, int i, int j,
                        int samples, float *out)
{
    double start[3], dir[3];
    memset(out, 0, sizeof *out * (size_t)samples);
    if (!s->ray(s->grid, i, j, start, dir))
        return 0;
    vs_march_state m = vs_march_begin(vs_vec3((float)start[0], (float)start[1], (float)start[2]),
                                      vs_vec3((float)dir[0], (float)dir[1], (float)dir[2]),
                                      s->t[samples - 1], s->box_lo, s->box_hi, s->density_scale);
    for (int k = 1; k < samples; ++k) {
        vs_march_advance(s->buf, acc, &m, s->t[k]);
        /* Past VS_TAU_LIMIT the march stops: the transmittance is 0 in float from there. */
        out[k] = vs_accum_value(m.tau);
    }
    return out[samples - 1] > 0.0f;
}

/* Sweeps every column of c (n set) in parallel, rows into their own buffers, then packs the
 * columns that met density. */
static vdbs_status columns_build(vdbs_light_columns *c, const column_sweep *s, vdbs_error *err)
{
    const int nu = c->n[0], nv = c->n[1], nw = c->n[2];
    int64_t columns = (int64_t)nu * nv;
    if (columns * nw > MAX_SAMPLES)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "light grid of %dx%dx%d samples is too large; lower the oversample",
                              nu, nv, nw);
    c->column = malloc(sizeof *c->column * (size_t)columns);
    float **rows = calloc((size_t)nv, sizeof *rows);
    int *row_count = calloc((size_t)nv, sizeof *row_count);
    int failed = !c->column || !rows || !row_count;

#pragma omp parallel if (!failed)
    {
        pnanovdb_readaccessor_t acc = vs_density_accessor(s->buf);
        float *scratch = malloc(sizeof *scratch * (size_t)nw);
#pragma omp for schedule(dynamic, 1)
        for (int j = 0; j < nv; ++j) {
            float *row = NULL;
            int stored = 0, capacity = 0;
            for (int i = 0; i < nu && scratch; ++i) {
                int64_t *slot = &c->column[(int64_t)j * nu + i];
                *slot = -1;
                if (!sweep_column(s, &acc, i, j, nw, scratch))
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
                *slot = stored++; /* row-local until packed */
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
    for (int j = 0; rows && j < nv; ++j)
        total += row_count[j];
    if (!failed)
        c->depth = malloc(sizeof *c->depth * (size_t)(total > 0 ? total : 1) * (size_t)nw);
    if (failed || !c->depth) {
        for (int j = 0; rows && j < nv; ++j)
            free(rows[j]);
        free(rows);
        free(row_count);
        columns_free(c);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    }
    int64_t at = 0;
    for (int j = 0; j < nv; ++j) {
        if (row_count[j] > 0)
            memcpy(c->depth + at * nw, rows[j], sizeof *c->depth * (size_t)row_count[j] * nw);
        for (int i = 0; i < nu; ++i) {
            int64_t *slot = &c->column[(int64_t)j * nu + i];
            if (*slot >= 0)
                *slot = (at + *slot) * nw;
        }
        at += row_count[j];
        free(rows[j]);
    }
    free(rows);
    free(row_count);
    c->stored = total;
    c->empty = columns - total;
    return VDBS_OK;
}

/* Depth of column (i, j) at sample k + f (k in [0, n[2] - 1]), linear along the column. */
static double column_depth(const vdbs_light_columns *c, int i, int j, int k, double f)
{
    int64_t at = c->column[(int64_t)j * c->n[0] + i];
    if (at < 0)
        return 0.0;
    const float *d = c->depth + at;
    return k + 1 < c->n[2] ? d[k] + f * ((double)d[k + 1] - d[k]) : d[k];
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

static int clampi(int i, int n)
{
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

/* Sample distances 0, t1, t2, ... for a sweep (floats, as the march measures t). */
static float *distances(int n, double (*radius)(const void *grid, int k), const void *grid)
{
    float *t = malloc(sizeof *t * (size_t)n);
    for (int k = 0; t && k < n; ++k)
        t[k] = (float)radius(grid, k);
    return t;
}

/* Sweeps every column of `columns` (n set): column (i, j) is the march `ray` gives, stopping
 * at the distances radius(grid, k). */
static vdbs_status sweep(const vdbs_volume *volume, double density_scale,
                         vdbs_light_columns *columns,
                         int (*ray)(const void *grid, int i, int j, double start[3], double dir[3]),
                         double (*radius)(const void *grid, int k), const void *grid,
                         vdbs_error *err)
{
    column_sweep s;
    memset(&s, 0, sizeof s);
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    s.volume = volume;
    s.buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    s.box_lo = vs_vec3(lo[0], lo[1], lo[2]);
    s.box_hi = vs_vec3(hi[0], hi[1], hi[2]);
    s.density_scale = (float)density_scale;
    s.ray = ray;
    s.grid = grid;
    float *t = distances(columns->n[2], radius, grid);
    if (!t)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    s.t = t;
    vdbs_status st = columns_build(columns, &s, err);
    free(t);
    return st;
}

/* ---- directional grids ---- */

void vdbs_dir_grid_free(vdbs_dir_grid *grid)
{
    if (!grid)
        return;
    columns_free(&grid->columns);
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

typedef struct dir_ray {
    const vdbs_dir_grid *grid;
    double origin_index[3], step_u[3], step_v[3], dir[3]; /* index space */
} dir_ray;

static int dir_column_ray(const void *user, int i, int j, double start[3], double dir[3])
{
    const dir_ray *r = user;
    for (int a = 0; a < 3; ++a) {
        start[a] = r->origin_index[a] + i * r->step_u[a] + j * r->step_v[a];
        dir[a] = r->dir[a];
    }
    return 1;
}

static double dir_radius(const void *user, int k)
{
    return ((const dir_ray *)user)->grid->h * k;
}

vdbs_status vdbs_dir_grid_build(const vdbs_volume *volume, double density_scale,
                                const double travel[3], const vdbs_light_grid_desc *desc,
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
    g->h = min_voxel_length(volume) / oversample_of(desc);

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
        double count = ceil(cmax[a] - 1e-9) - first[a] + 1.0;
        if (count > 1e9)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "light grid: %g samples along an axis",
                                  count);
        g->columns.n[a] = (int)count;
    }
    for (int a = 0; a < 3; ++a)
        g->origin[a] =
            base[a] + first[0] * g->h * u[a] + first[1] * g->h * v[a] + first[2] * g->h * w[a];

    dir_ray ray = {g, {0}, {0}, {0}, {0}};
    double step_u[3] = {u[0] * g->h, u[1] * g->h, u[2] * g->h};
    double step_v[3] = {v[0] * g->h, v[1] * g->h, v[2] * g->h};
    vdbs_volume_index_point(volume, g->origin, ray.origin_index);
    vdbs_volume_index_vector(volume, step_u, ray.step_u);
    vdbs_volume_index_vector(volume, step_v, ray.step_v);
    vdbs_volume_index_vector(volume, w, ray.dir);
    return sweep(volume, density_scale, &g->columns, dir_column_ray, dir_radius, &ray, err);
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

double vdbs_dir_grid_depth(const vdbs_dir_grid *g, const double world[3])
{
    const vdbs_light_columns *c = &g->columns;
    double d[3] = {world[0] - g->origin[0], world[1] - g->origin[1], world[2] - g->origin[2]};
    double fu, fv, fw;
    int i = split(dot3(d, g->axes[0]) / g->h, c->n[0], &fu);
    int j = split(dot3(d, g->axes[1]) / g->h, c->n[1], &fv);
    int k = split(dot3(d, g->axes[2]) / g->h, c->n[2], &fw);
    double wu[4], wv[4];
    catmull_rom(fu, wu);
    catmull_rom(fv, wv);
    double sum = 0.0, lo = HUGE_VAL, hi = -HUGE_VAL;
    for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) {
            double x =
                column_depth(c, clampi(i + a - 1, c->n[0]), clampi(j + b - 1, c->n[1]), k, fw);
            sum += wu[a] * wv[b] * x;
            if (a >= 1 && a <= 2 && b >= 1 && b <= 2) {
                lo = fmin(lo, x);
                hi = fmax(hi, x);
            }
        }
    /* No overshoot beyond the four nearest columns (sharp edges of the medium). */
    return fmin(fmax(sum, lo), hi);
}

/* ---- radial grids ---- */

void vdbs_radial_grid_free(vdbs_radial_grid *grid)
{
    if (!grid)
        return;
    columns_free(&grid->columns);
    free(grid->radius);
    memset(grid, 0, sizeof *grid);
}

/* Octahedral map of the unit sphere onto [-1, 1]^2 (continuous on the upper half; the lower
 * half folds over the diagonals). */
static void octahedral_encode(const double d[3], double p[2])
{
    double n = fabs(d[0]) + fabs(d[1]) + fabs(d[2]);
    double x = d[0] / n, y = d[1] / n;
    if (d[2] < 0.0) {
        double fx = (1.0 - fabs(y)) * copysign(1.0, x);
        double fy = (1.0 - fabs(x)) * copysign(1.0, y);
        x = fx;
        y = fy;
    }
    p[0] = x;
    p[1] = y;
}

static void octahedral_decode(const double p[2], double d[3])
{
    double x = p[0], y = p[1], z = 1.0 - fabs(x) - fabs(y);
    if (z < 0.0) {
        double fx = (1.0 - fabs(y)) * copysign(1.0, x);
        double fy = (1.0 - fabs(x)) * copysign(1.0, y);
        x = fx;
        y = fy;
    }
    double n = sqrt(x * x + y * y + z * z);
    d[0] = x / n;
    d[1] = y / n;
    d[2] = z / n;
}

typedef struct radial_ray {
    const vdbs_radial_grid *grid;
    const vdbs_volume *volume;
    double position_index[3];
} radial_ray;

static int radial_column_ray(const void *user, int i, int j, double start[3], double dir[3])
{
    const radial_ray *r = user;
    int n = r->grid->resolution;
    double p[2] = {2.0 * (i + 0.5) / n - 1.0, 2.0 * (j + 0.5) / n - 1.0}, d[3];
    octahedral_decode(p, d);
    vdbs_volume_index_vector(r->volume, d, dir);
    memcpy(start, r->position_index, sizeof r->position_index);
    return 1;
}

static double radial_radius(const void *user, int k)
{
    return ((const radial_ray *)user)->grid->radius[k];
}

vdbs_status vdbs_radial_grid_build(const vdbs_volume *volume, double density_scale,
                                   const double position[3], const vdbs_light_grid_desc *desc,
                                   vdbs_radial_grid *g, vdbs_error *err)
{
    memset(g, 0, sizeof *g);
    memcpy(g->position, position, sizeof g->position);
    double h = min_voxel_length(volume) / oversample_of(desc);
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    double r_max = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
        double idx[3] = {corner & 1 ? hi[0] : lo[0], corner & 2 ? hi[1] : lo[1],
                         corner & 4 ? hi[2] : lo[2]};
        double p[3], d[3];
        vdbs_volume_world_point(volume, idx, p);
        for (int a = 0; a < 3; ++a)
            d[a] = p[a] - position[a];
        r_max = fmax(r_max, sqrt(dot3(d, d)));
    }
    /* Texels of about h at r_max: an octahedral texel spans up to pi / resolution radians. */
    double resolution = ceil(VDBS_PI * r_max / h);
    g->resolution = (int)fmin(fmax(resolution, 8.0), MAX_RESOLUTION);
    /* Shells h apart, or a texel's width apart where that is wider; the last beyond r_max. */
    double texel = VDBS_PI / g->resolution;
    int shells = 1;
    for (double r = 0.0; r < r_max; r += fmax(h, texel * r))
        ++shells;
    g->radius = malloc(sizeof *g->radius * (size_t)shells);
    if (!g->radius)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    g->radius[0] = 0.0;
    for (int k = 1; k < shells; ++k)
        g->radius[k] = g->radius[k - 1] + fmax(h, texel * g->radius[k - 1]);
    g->columns.n[0] = g->columns.n[1] = g->resolution;
    g->columns.n[2] = shells;

    radial_ray ray = {g, volume, {0}};
    vdbs_volume_index_point(volume, position, ray.position_index);
    vdbs_status st =
        sweep(volume, density_scale, &g->columns, radial_column_ray, radial_radius, &ray, err);
    /* Also on a failed sweep: the shell radii are allocated. */
    if (st != VDBS_OK)
        vdbs_radial_grid_free(g);
    return st;
}

double vdbs_radial_grid_depth(const vdbs_radial_grid *g, const double world[3])
{
    const vdbs_light_columns *c = &g->columns;
    double v[3] = {world[0] - g->position[0], world[1] - g->position[1], world[2] - g->position[2]};
    double r = sqrt(dot3(v, v));
    if (!(r > 0.0))
        return 0.0;
    double d[3] = {v[0] / r, v[1] / r, v[2] / r}, p[2];
    octahedral_encode(d, p);
    double fu, fv, fr;
    int i = split(0.5 * (p[0] + 1.0) * g->resolution - 0.5, c->n[0], &fu);
    int j = split(0.5 * (p[1] + 1.0) * g->resolution - 0.5, c->n[1], &fv);
    /* The shell below r (binary search), then linear in r to the next. */
    int k = 0, top = c->n[2] - 1;
    if (r >= g->radius[top]) {
        k = top;
        fr = 0.0;
    } else {
        while (top - k > 1) {
            int mid = (k + top) / 2;
            if (g->radius[mid] <= r)
                k = mid;
            else
                top = mid;
        }
        fr = (r - g->radius[k]) / (g->radius[k + 1] - g->radius[k]);
    }
    int i1 = i + 1 < c->n[0] ? i + 1 : i, j1 = j + 1 < c->n[1] ? j + 1 : j;
    double d00 = column_depth(c, i, j, k, fr), d10 = column_depth(c, i1, j, k, fr);
    double d01 = column_depth(c, i, j1, k, fr), d11 = column_depth(c, i1, j1, k, fr);
    double d0 = d00 + fu * (d10 - d00), d1 = d01 + fu * (d11 - d01);
    return d0 + fv * (d1 - d0);
}
