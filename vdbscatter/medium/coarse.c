#include "vdbscatter/coarse.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

void vdbs_coarse_fit(const double corners[8][3], const double axis[3][3], double h,
                     vdbs_coarse_frame *f)
{
    memcpy(f->axis, axis, sizeof f->axis);
    f->h = h;
    f->side[0] = f->side[1] = f->side[2] = h;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int c = 0; c < 8; ++c)
        for (int a = 0; a < 3; ++a) {
            double x = dot3(corners[c], axis[a]);
            lo[a] = fmin(lo[a], x);
            hi[a] = fmax(hi[a], x);
        }
    for (int k = 0; k < 3; ++k)
        f->origin[k] = 0.0;
    for (int a = 0; a < 3; ++a) {
        f->n[a] = (int)ceil((hi[a] - lo[a]) / h - 1e-9);
        if (f->n[a] < 1)
            f->n[a] = 1;
        for (int k = 0; k < 3; ++k)
            f->origin[k] += lo[a] * axis[a][k];
    }
}

int vdbs_coarse_world_frame(const vdbs_volume *volume, int resolution, int min_across,
                            vdbs_coarse_frame *f)
{
    double corners[8][3];
    vdbs_volume_support_corners(volume, corners);
    const double extent = vdbs_volume_support_extent(volume);
    const int voxels_across = (int)ceil(extent / volume->mean_voxel_size - 1e-9);
    if (resolution > voxels_across)
        resolution = voxels_across;
    if (resolution < 1)
        resolution = 1;
    const double world_axes[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const double h = extent / resolution;
    vdbs_coarse_fit(corners, world_axes, h, f);
    if (min_across <= 1)
        return resolution;
    /* Short axes: min_across cells across their own extent, no finer than a voxel, fewer
     * where the cube's cell count would be exceeded (the same count for every short axis). */
    int want[3];
    double length[3];
    for (int a = 0; a < 3; ++a) {
        double lo = HUGE_VAL, hi = -HUGE_VAL;
        for (int c = 0; c < 8; ++c) {
            lo = fmin(lo, corners[c][a]);
            hi = fmax(hi, corners[c][a]);
        }
        length[a] = hi - lo;
        const int voxels = (int)ceil(length[a] / volume->mean_voxel_size - 1e-9);
        want[a] = f->n[a];
        if (f->n[a] < min_across && length[a] > 0.0)
            want[a] = min_across < voxels ? min_across : (voxels > f->n[a] ? voxels : f->n[a]);
    }
    const double cap = (double)resolution * resolution * resolution;
    for (int across = min_across; across > 1; --across) {
        int n[3];
        for (int a = 0; a < 3; ++a)
            n[a] = want[a] > f->n[a] ? (want[a] < across ? want[a] : across) : f->n[a];
        for (int a = 0; a < 3; ++a)
            n[a] = n[a] > f->n[a] ? n[a] : f->n[a];
        if ((double)n[0] * n[1] * n[2] > cap)
            continue;
        for (int a = 0; a < 3; ++a)
            if (n[a] > f->n[a]) {
                /* The short axis's cells span its extent exactly from the box's low side
                 * (the fitted origin along a world axis). */
                f->n[a] = n[a];
                f->side[a] = length[a] / n[a];
            }
        break;
    }
    return resolution;
}

int64_t vdbs_coarse_cells(const vdbs_coarse_frame *f)
{
    return (int64_t)f->n[0] * f->n[1] * f->n[2];
}

double vdbs_coarse_cell_volume(const vdbs_coarse_frame *f)
{
    return f->side[0] * f->side[1] * f->side[2];
}

void vdbs_coarse_point(const vdbs_coarse_frame *f, const double x[3], double world[3])
{
    if (f->side[0] == f->h && f->side[1] == f->h && f->side[2] == f->h) {
        /* Cubic: as before anisotropic cells, to the bit. */
        for (int k = 0; k < 3; ++k)
            world[k] = f->origin[k] +
                       f->h * (x[0] * f->axis[0][k] + x[1] * f->axis[1][k] + x[2] * f->axis[2][k]);
        return;
    }
    for (int k = 0; k < 3; ++k)
        world[k] = f->origin[k] + x[0] * f->side[0] * f->axis[0][k] +
                   x[1] * f->side[1] * f->axis[1][k] + x[2] * f->side[2] * f->axis[2][k];
}

void vdbs_coarse_cell_centre(const vdbs_coarse_frame *f, int64_t c, double world[3])
{
    double x[3] = {(double)(c % f->n[0]) + 0.5, (double)((c / f->n[0]) % f->n[1]) + 0.5,
                   (double)(c / ((int64_t)f->n[0] * f->n[1])) + 0.5};
    vdbs_coarse_point(f, x, world);
}

/* The trilinear footing of world point p: the lower of the 8 cell centres around it and
 * the fractions towards the upper ones (coordinates may fall outside the grid). */
static void coarse_trilinear(const vdbs_coarse_frame *f, const double p[3], int i0[3],
                             double frac[3])
{
    double rel[3] = {p[0] - f->origin[0], p[1] - f->origin[1], p[2] - f->origin[2]};
    for (int a = 0; a < 3; ++a) {
        double x = dot3(rel, f->axis[a]) / f->side[a] - 0.5;
        double fl = floor(x);
        i0[a] = (int)fl;
        frac[a] = x - fl;
    }
}

static int64_t coarse_index(const vdbs_coarse_frame *f, const int idx[3])
{
    return ((int64_t)idx[2] * f->n[1] + idx[1]) * f->n[0] + idx[0];
}

void vdbs_coarse_sigma(const vdbs_coarse_frame *f, const vdbs_volume *volume,
                       const vdbs_medium_box *box, double density_scale, float *sigma)
{
    const int64_t cells = vdbs_coarse_cells(f);
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < cells; ++c) {
        double w[3], idx[3];
        vdbs_coarse_cell_centre(f, c, w);
        vdbs_volume_index_point(volume, w, idx);
        sigma[c] = (float)(density_scale * vdbs_medium_box_density(box, idx));
    }
}

/* The trilinear weights of p's eight surrounding cells, renormalised over the cells inside
 * the grid and, with a mask, over those whose mask is > 0 (none: every weight 0); without a
 * mask the nearest cell alone beyond the outer centres on every side. */
static void coarse_weights(const vdbs_coarse_frame *dst, const double p[3], const float *mask,
                           double w[8], int64_t at[8])
{
    int i0[3];
    double f[3];
    coarse_trilinear(dst, p, i0, f);
    double wsum = 0.0;
    for (int c = 0; c < 8; ++c) {
        w[c] = 1.0;
        int inside = 1;
        int idx[3];
        for (int a = 0; a < 3; ++a) {
            int bit = (c >> a) & 1;
            idx[a] = i0[a] + bit;
            w[c] *= bit ? f[a] : 1.0 - f[a];
            inside &= idx[a] >= 0 && idx[a] < dst->n[a];
        }
        at[c] = inside ? coarse_index(dst, idx) : 0;
        if (!inside || (mask && !(mask[at[c]] > 0.0f)))
            w[c] = 0.0;
        wsum += w[c];
    }
    if (mask && !(wsum > 0.0)) {
        for (int c = 0; c < 8; ++c)
            w[c] = 0.0;
        return;
    }
    if (!(wsum > 0.0)) {
        /* Beyond the grid's outer centres on every side: the nearest cell takes it. */
        int idx[3];
        for (int a = 0; a < 3; ++a) {
            idx[a] = i0[a] + (f[a] >= 0.5);
            idx[a] = idx[a] < 0 ? 0 : (idx[a] >= dst->n[a] ? dst->n[a] - 1 : idx[a]);
        }
        w[0] = wsum = 1.0;
        at[0] = coarse_index(dst, idx);
        for (int c = 1; c < 8; ++c)
            w[c] = 0.0;
    }
    for (int c = 0; c < 8; ++c)
        w[c] /= wsum;
}

int vdbs_coarse_splat_masked(const vdbs_coarse_frame *dst, double *acc, int width,
                             const double p[3], const double *values, double scale,
                             const float *mask)
{
    double w[8];
    int64_t at[8];
    coarse_weights(dst, p, mask, w, at);
    int any = 0;
    for (int c = 0; c < 8; ++c) {
        if (w[c] == 0.0)
            continue;
        any = 1;
        double s = scale * w[c];
        for (int v = 0; v < width; ++v)
            acc[at[c] * width + v] += s * values[v];
    }
    return any;
}

void vdbs_coarse_splat(const vdbs_coarse_frame *dst, double *acc, int width, const double p[3],
                       const double *values, double scale)
{
    (void)vdbs_coarse_splat_masked(dst, acc, width, p, values, scale, NULL);
}

void vdbs_coarse_sample(const vdbs_coarse_frame *f, const float *values, int width,
                        const double p[3], double *out)
{
    double w[8];
    int64_t at[8];
    coarse_weights(f, p, NULL, w, at);
    for (int v = 0; v < width; ++v)
        out[v] = 0.0;
    for (int c = 0; c < 8; ++c)
        for (int v = 0; w[c] != 0.0 && v < width; ++v)
            out[v] += w[c] * (double)values[at[c] * width + v];
}

void vdbs_coarse_ms_values(int64_t cells, const double *phi, const double *flux, double g,
                           double *values)
{
    const double l1 = 3.0 * g * VDBS_INV_4PI;
    for (int64_t c = 0; c < cells; ++c)
        for (int ch = 0; ch < 3; ++ch) {
            values[VDBS_COARSE_WIDTH * c + VDBS_COARSE_MS + ch] =
                fmax(phi[3 * c + ch], 0.0) * VDBS_INV_4PI;
            for (int a = 0; a < 3; ++a)
                values[VDBS_COARSE_WIDTH * c + VDBS_COARSE_L1 + 3 * a + ch] =
                    flux ? l1 * flux[9 * c + 3 * a + ch] : 0.0;
        }
}

/* Per axis, the cells whose weights are non-zero at grid coordinate x (in cells, centres at
 * integer + 0.5) and those weights: trilinear's 2 or the cubic B-spline's 4. Indices are
 * clamped to the grid, so that beyond the outer centres the edge cell's value continues
 * (a clamped cell takes the weight of the one it stands for). */
static int axis_taps(vdbs_coarse_kernel kernel, double x, int n, int idx[4], double w[4])
{
    double fl = floor(x - 0.5);
    double t = x - 0.5 - fl;
    int i0 = (int)fl, taps;
    if (kernel == VDBS_COARSE_TRILINEAR) {
        idx[0] = i0;
        idx[1] = i0 + 1;
        w[0] = 1.0 - t;
        w[1] = t;
        taps = 2;
    } else {
        /* The uniform cubic B-spline: C2 across cell boundaries, weights >= 0 summing to 1. */
        const double t2 = t * t, t3 = t2 * t, s = 1.0 - t;
        for (int k = 0; k < 4; ++k)
            idx[k] = i0 - 1 + k;
        w[0] = s * s * s / 6.0;
        w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
        w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
        w[3] = t3 / 6.0;
        taps = 4;
    }
    for (int k = 0; k < taps; ++k)
        idx[k] = idx[k] < 0 ? 0 : (idx[k] >= n ? n - 1 : idx[k]);
    return taps;
}

/* In place along one line of n samples `stride` apart: the cubic B-spline's interpolation
 * coefficients (Unser's recursive filter, pole sqrt(3) - 2, mirror boundaries), so that the
 * spline through them passes through the samples at the cell centres. */
static void prefilter_line(double *c, int64_t n, int64_t stride)
{
    if (n < 2)
        return;
    const double z = sqrt(3.0) - 2.0;
    for (int64_t k = 0; k < n; ++k)
        c[k * stride] *= 6.0; /* (1 - z)(1 - 1/z) */
    /* The causal filter's start: the mirrored sequence summed exactly. */
    double zn = z, z2n = pow(z, (double)(n - 1));
    double sum = c[0] + z2n * c[(n - 1) * stride];
    z2n *= z2n / z;
    for (int64_t k = 1; k < n - 1; ++k) {
        sum += (zn + z2n) * c[k * stride];
        zn *= z;
        z2n /= z;
    }
    c[0] = sum / (1.0 - zn * zn);
    for (int64_t k = 1; k < n; ++k)
        c[k * stride] += z * c[(k - 1) * stride];
    c[(n - 1) * stride] = z / (z * z - 1.0) * (z * c[(n - 2) * stride] + c[(n - 1) * stride]);
    for (int64_t k = n - 2; k >= 0; --k)
        c[k * stride] = z * (c[(k + 1) * stride] - c[k * stride]);
}

/* values' interpolation coefficients for the cubic B-spline, every channel, along x, y, z. */
static void prefilter(const vdbs_coarse_frame *f, double *values)
{
    const int64_t step[3] = {VDBS_COARSE_WIDTH, (int64_t)VDBS_COARSE_WIDTH * f->n[0],
                             (int64_t)VDBS_COARSE_WIDTH * f->n[0] * f->n[1]};
    for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, c = (a + 2) % 3;
#pragma omp parallel for schedule(static)
        for (int k = 0; k < f->n[c]; ++k)
            for (int j = 0; j < f->n[b]; ++j)
                for (int v = 0; v < VDBS_COARSE_WIDTH; ++v)
                    prefilter_line(values + k * step[c] + j * step[b] + v, f->n[a], step[a]);
    }
}

vdbs_status vdbs_coarse_upsample(const vdbs_coarse_frame *f, const double *values,
                                 const vdbs_volume *volume, const vdbs_medium_box *box,
                                 double density_scale, vdbs_coarse_kernel kernel, float *ms,
                                 float *const ms_l1[3], float *radiance, vdbs_error *err)
{
    const double scale = density_scale;
    const int64_t cells = vdbs_coarse_cells(f);
    float *guide = malloc(sizeof *guide * (size_t)cells);
    if (!guide)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the upsampling guide");
    vdbs_coarse_sigma(f, volume, box, scale, guide);
    double sum = 0.0;
    int64_t count = 0;
    for (int64_t c = 0; c < cells; ++c)
        if (guide[c] > 0.0f) {
            sum += guide[c];
            ++count;
        }
    const double range = count > 0 ? 0.5 * sum / count : 1.0;
    double *coef = NULL;
    const int smoothing = kernel == VDBS_COARSE_BSPLINE;
    if (kernel == VDBS_COARSE_BSPLINE_INTERP) {
        coef = malloc(sizeof *coef * (size_t)cells * VDBS_COARSE_WIDTH);
        if (!coef) {
            free(guide);
            return vdbs_error_set(err, VDBS_ERR_NOMEM,
                                  "out of memory for the upsampling coefficients");
        }
        memcpy(coef, values, sizeof *coef * (size_t)cells * VDBS_COARSE_WIDTH);
        prefilter(f, coef);
        values = coef;
    }
    const vdbs_coarse_kernel taps_kernel =
        kernel == VDBS_COARSE_TRILINEAR ? VDBS_COARSE_TRILINEAR : VDBS_COARSE_BSPLINE;
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
#pragma omp parallel
    {
        pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
#pragma omp for schedule(static)
        for (int64_t n = 0; n < (int64_t)volume->coord_count; ++n) {
            const int32_t *co = volume->coords + 3 * n;
            double idx[3] = {co[0], co[1], co[2]}, w[3];
            vdbs_volume_world_point(volume, idx, w);
            double sv = scale * vs_density_voxel(buf, &acc, vs_coord(co[0], co[1], co[2]));
            double rel[3] = {w[0] - f->origin[0], w[1] - f->origin[1], w[2] - f->origin[2]};
            int at[3][4], taps[3];
            double aw[3][4];
            for (int a = 0; a < 3; ++a)
                taps[a] = axis_taps(taps_kernel, dot3(rel, f->axis[a]) / f->side[a], f->n[a], at[a],
                                    aw[a]);
            double out[VDBS_COARSE_WIDTH] = {0}, wsum = 0.0;
            double hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
            for (int k = 0; k < taps[2]; ++k)
                for (int j = 0; j < taps[1]; ++j)
                    for (int i = 0; i < taps[0]; ++i) {
                        const int id[3] = {at[0][i], at[1][j], at[2][k]};
                        int64_t c = coarse_index(f, id);
                        /* The smoothing spline spreads a cell's value over the cells beyond
                         * its neighbours: where the light falls within a cell (the lit skin
                         * of a medium thick in absorption) it puts light deeper in than the
                         * cells there hold, which the voxels there absorb, creating energy.
                         * Each voxel's ms stays at most the largest of the 2 x 2 x 2 cells
                         * around it (the inner taps); ms_l1 follows through its bound. */
                        if (smoothing && i % 3 && j % 3 && k % 3)
                            for (int ch = 0; ch < 3; ++ch)
                                hi[ch] = fmax(hi[ch],
                                              values[c * VDBS_COARSE_WIDTH + VDBS_COARSE_MS + ch]);
                        double wt = aw[0][i] * aw[1][j] * aw[2][k];
                        if (wt == 0.0)
                            continue;
                        /* The joint bilateral factor: cells whose medium differs from the
                         * voxel's count less (an edge in the density is an edge in ms). */
                        double dr = (guide[c] - sv) / range;
                        wt *= exp(-0.5 * dr * dr) + 1e-3;
                        wsum += wt;
                        for (int v = 0; v < VDBS_COARSE_WIDTH; ++v)
                            out[v] += wt * values[c * VDBS_COARSE_WIDTH + v];
                    }
            if (!(wsum > 0.0))
                continue;
            for (int ch = 0; ch < 3; ++ch) {
                double x = out[VDBS_COARSE_MS + ch] / wsum;
                if (smoothing)
                    x = fmin(x, hi[ch]);
                /* The interpolating spline overshoots next to sharp changes: ms >= 0. */
                float v = (float)fmax(x, 0.0);
                ms[3 * n + ch] += v;
                if (radiance)
                    radiance[3 * n + ch] += v;
                for (int a = 0; a < 3; ++a)
                    ms_l1[a][3 * n + ch] += (float)(out[VDBS_COARSE_L1 + 3 * a + ch] / wsum);
            }
        }
    }
    free(guide);
    free(coef);
    return VDBS_OK;
}
