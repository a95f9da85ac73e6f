/* Procedural sample volumes over [-1,1]^3.
 *
 * Determinism: the noise is gradient (Perlin-style) noise whose lattice gradients come from
 * a 32-bit integer hash of (i, j, k, seed), so it does not depend on libc's rand or on any
 * platform function. The shapes use only +, -, *, /, sqrt and floor on doubles (all exactly
 * rounded in IEEE arithmetic; no exp/pow/sin, whose libm results differ between systems),
 * and the project builds in ISO C mode, where gcc does not contract a*b+c into an FMA.
 * Every value is a continuous function of the voxel centre's world position, so the same
 * seed gives the same shape at every resolution. */
#include "vdbscatter/samples.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

const char *const vdbs_sample_names[] = {"cloud", "smoke", "sphere", "slab", "cube", NULL};

/* ---- integer hash and gradient noise ---- */

/* "lowbias32" (C. Wellons): a 32-bit integer mixer with full avalanche. */
static uint32_t mix32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

/* Signed lattice coordinates convert to uint32_t modulo 2^32, which C defines exactly. */
static uint32_t hash4(int32_t i, int32_t j, int32_t k, uint32_t seed)
{
    uint32_t h = mix32(seed ^ 0x9e3779b9U);
    h = mix32(h ^ (uint32_t)i);
    h = mix32(h ^ (uint32_t)j);
    return mix32(h ^ (uint32_t)k);
}

/* A number in [0, 1) from the top 24 bits of a hash (exact in double). */
static double unit(uint32_t h)
{
    return (double)(h >> 8) * (1.0 / 16777216.0);
}

/* Dot product with one of Perlin's 12 cube-edge gradients (4 repeated to make 16). */
static double grad(uint32_t h, double x, double y, double z)
{
    switch (h >> 28) {
    case 0:
    case 12:
        return x + y;
    case 1:
    case 13:
        return -x + y;
    case 2:
        return x - y;
    case 3:
        return -x - y;
    case 4:
        return x + z;
    case 5:
        return -x + z;
    case 6:
        return x - z;
    case 7:
        return -x - z;
    case 8:
        return y + z;
    case 9:
    case 14:
        return -y + z;
    case 10:
        return y - z;
    default:
        return -y - z;
    }
}

static double fade(double t)
{
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

static double lerp(double a, double b, double t)
{
    return a + t * (b - a);
}

/* Gradient noise, C2-continuous, roughly in [-1, 1]. */
static double gnoise(double x, double y, double z, uint32_t seed)
{
    double fx = floor(x), fy = floor(y), fz = floor(z);
    int32_t ix = (int32_t)fx, iy = (int32_t)fy, iz = (int32_t)fz;
    double tx = x - fx, ty = y - fy, tz = z - fz;
    double u = fade(tx), v = fade(ty), w = fade(tz);
    double c[2][2];
    for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
            double n0 = grad(hash4(ix, iy + a, iz + b, seed), tx, ty - a, tz - b);
            double n1 = grad(hash4(ix + 1, iy + a, iz + b, seed), tx - 1.0, ty - a, tz - b);
            c[b][a] = lerp(n0, n1, u);
        }
    return lerp(lerp(c[0][0], c[0][1], v), lerp(c[1][0], c[1][1], v), w);
}

/* Fractal sum of `octaves` octaves (lacunarity 2, gain 1/2), normalised by the total
 * amplitude and clamped to [-1, 1] so that callers may rely on that bound to skip empty
 * space without changing any value. Each octave has its own seed and offset, so the
 * lattices of successive octaves do not line up (gradient noise is 0 on its lattice). */
static double fbm(double x, double y, double z, uint32_t seed, int octaves)
{
    double sum = 0.0, amp = 1.0, total = 0.0, f = 1.0;
    for (int o = 0; o < octaves; ++o) {
        double off = 0.371 * o;
        sum += amp * gnoise(x * f + off, y * f + 1.7 * off, z * f - off, seed + 0x632be5abU * o);
        total += amp;
        amp *= 0.5;
        f *= 2.0;
    }
    /* The sum's standard deviation is about 0.16 of the total amplitude; doubling it
     * spreads the values over most of [-1, 1] (std 0.32, rarely clamped). */
    sum = 2.0 * sum / total;
    return sum < -1.0 ? -1.0 : (sum > 1.0 ? 1.0 : sum);
}

static double smoothstep(double e0, double e1, double x)
{
    double t = (x - e0) / (e1 - e0);
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    return t * t * (3.0 - 2.0 * t);
}

/* 1 inside, ramping to 0 near the faces of [-1,1]^3: the active region never touches
 * the border of the grid, whatever the noise does. */
static double border_fade(double x, double y, double z)
{
    double m = fmax(fabs(x), fmax(fabs(y), fabs(z)));
    return 1.0 - smoothstep(0.9, 0.97, m);
}

/* ---- cloud: flat-based cumulus of ellipsoid blobs eroded by fBm ---- */

#define CLOUD_BLOBS 7

typedef struct cloud_params {
    double c[CLOUD_BLOBS][3];
    double inv_r[CLOUD_BLOBS][3];
    uint32_t shape_seed, detail_seed;
} cloud_params;

static void cloud_init(cloud_params *cp, uint32_t seed)
{
    /* Centre and radii: a wide, flat main body with towers rising from it. */
    static const double base[CLOUD_BLOBS][6] = {
        {0.00, -0.12, 0.00, 0.66, 0.36, 0.52},  {-0.30, 0.06, 0.08, 0.38, 0.38, 0.36},
        {0.28, 0.10, -0.08, 0.36, 0.40, 0.34},  {0.02, 0.30, 0.04, 0.30, 0.32, 0.28},
        {0.46, -0.10, 0.20, 0.26, 0.24, 0.26},  {-0.48, -0.14, -0.16, 0.26, 0.22, 0.24},
        {-0.10, 0.16, -0.26, 0.30, 0.30, 0.26},
    };
    for (int b = 0; b < CLOUD_BLOBS; ++b)
        for (int a = 0; a < 3; ++a) {
            /* Each seed moves the blobs by up to 0.06 and scales them by 0.9-1.1. */
            double jc = unit(hash4(b, a, 1, seed)) * 2.0 - 1.0;
            double jr = unit(hash4(b, a, 2, seed));
            cp->c[b][a] = base[b][a] + 0.06 * jc;
            cp->inv_r[b][a] = 1.0 / (base[b][3 + a] * (0.9 + 0.2 * jr));
        }
    cp->shape_seed = hash4(0, 0, 3, seed);
    cp->detail_seed = hash4(0, 0, 4, seed);
}

static float cloud_value(const cloud_params *cp, double x, double y, double z)
{
    const double y_base = -0.30;
    double s = -1e30;
    for (int b = 0; b < CLOUD_BLOBS; ++b) {
        double dx = (x - cp->c[b][0]) * cp->inv_r[b][0];
        double dy = (y - cp->c[b][1]) * cp->inv_r[b][1];
        double dz = (z - cp->c[b][2]) * cp->inv_r[b][2];
        s = fmax(s, 1.0 - (dx * dx + dy * dy + dz * dz));
    }
    /* |n| <= 1, so field <= s + 0.6: nothing to compute where that is negative. */
    if (s < -0.6 || y < y_base - 0.05)
        return 0.0f;
    double n = fbm(2.5 * x, 2.5 * y, 2.5 * z, cp->shape_seed, 5);
    double field = s - 0.15 + 0.6 * n;
    /* Flat, slightly ragged base: cumulus bottoms sit on the condensation level. */
    double bottom = smoothstep(y_base - 0.05, y_base + 0.07, y + 0.03 * n);
    double d = smoothstep(0.0, 0.3, field) * bottom * border_fade(x, y, z);
    if (d <= 0.0)
        return 0.0f;
    double detail = fbm(7.0 * x, 7.0 * y, 7.0 * z, cp->detail_seed, 3);
    return (float)(d * (0.85 + 0.15 * detail));
}

/* ---- smoke: a plume rising from a narrow source, widening and billowing ---- */

typedef struct smoke_params {
    uint32_t sway_x_seed, sway_z_seed, shape_seed, detail_seed;
    /* The plume at time t in [0, 1] (vdbs_sample_fill_at), or the still sample (t < 0):
     * the head stands at `head_y` with half-axes head_r across and head_h up, and the
     * noise has risen by `rise`. */
    double head_y, head_r, head_h, rise;
} smoke_params;

#define SMOKE_Y0 (-0.85)
#define SMOKE_Y1 0.55

/* Speed of the rising billows, per unit of time. */
#define SMOKE_RISE_SPEED 0.5

static void smoke_init(smoke_params *sp, uint32_t seed, double time)
{
    sp->sway_x_seed = hash4(1, 0, 0, seed);
    sp->sway_z_seed = hash4(2, 0, 0, seed);
    sp->shape_seed = hash4(3, 0, 0, seed);
    sp->detail_seed = hash4(4, 0, 0, seed);
    sp->head_y = SMOKE_Y1 + 0.02;
    sp->head_r = 0.52;
    sp->head_h = 0.28;
    sp->rise = 0.0;
    if (time >= 0.0) {
        /* The head climbs from 30% of the final height to all of it; the column below it is
         * the still plume's, so the box grows from frame to frame.
         * The head stays wider than the column under it (r(t) = 0.09 + 0.40 t^1.5 below), so
         * cutting the column at the head leaves the surface continuous. */
        const double h = 0.3 + 0.7 * (time > 1.0 ? 1.0 : time);
        sp->head_y = SMOKE_Y0 + h * (sp->head_y - SMOKE_Y0);
        sp->head_r = 0.11 + 0.41 * h * sqrt(h);
        sp->head_h = 0.28 * (0.5 + 0.5 * h);
        sp->rise = SMOKE_RISE_SPEED * time;
    }
}

/* Per-height quantities: the centre line drifts more the higher the smoke has risen. */
typedef struct smoke_row {
    double cx, cz, r, t;
} smoke_row;

static smoke_row smoke_row_at(const smoke_params *sp, double y)
{
    smoke_row row;
    double t = (y - SMOKE_Y0) / (SMOKE_Y1 - SMOKE_Y0);
    double tc = t < 0.0 ? 0.0 : (t > 1.2 ? 1.2 : t);
    row.t = t;
    row.cx = 0.16 * tc * gnoise(0.5, 1.3 * y, 0.5, sp->sway_x_seed);
    row.cz = 0.16 * tc * gnoise(0.5, 1.3 * y, 0.5, sp->sway_z_seed);
    row.r = 0.09 + 0.40 * tc * sqrt(tc);
    return row;
}

static float smoke_value(const smoke_params *sp, const smoke_row *row, double x, double y, double z)
{
    const double head_y = sp->head_y;
    double dx = x - row->cx, dz = z - row->cz;
    double q = sqrt(dx * dx + dz * dz) / row->r;
    /* The column ends in a wider billowing head (an oblate ellipsoid). At y = head_y the
     * head is wider than the column (0.52 > r = 0.50), so cutting the column there leaves
     * max(s_col, s_head) continuous. */
    double hx = dx / sp->head_r, hy = (y - head_y) / sp->head_h, hz = dz / sp->head_r;
    double s_col = y <= head_y ? 1.0 - q : -1.0;
    double s_head = 1.0 - sqrt(hx * hx + hy * hy + hz * hz);
    double s = fmax(s_col, s_head);
    /* |n| <= 1: field <= s + 0.5. */
    if (s < -0.5 || y < SMOKE_Y0 - 0.03)
        return 0.0f;
    /* Vertically stretched noise, so the billows look drawn upwards. */
    double n = fbm(3.2 * x, 2.2 * (y - sp->rise), 3.2 * z, sp->shape_seed, 5);
    double field = s + 0.5 * n;
    double source = smoothstep(SMOKE_Y0 - 0.03, SMOKE_Y0 + 0.05, y);
    double thin = 1.0 - 0.2 * (row->t < 0.0 ? 0.0 : (row->t > 1.0 ? 1.0 : row->t));
    double d = smoothstep(0.0, 0.4, field) * source * thin * border_fade(x, y, z);
    if (d <= 0.0)
        return 0.0f;
    double detail = fbm(8.0 * x, 6.0 * (y - sp->rise), 8.0 * z, sp->detail_seed, 3);
    return (float)(d * (0.8 + 0.2 * detail));
}

/* ---- fill ---- */

/* Voxel-centre coordinate (2i + 1 - res) / res = -1 + (i + 0.5) * 2/res, written as one
 * division of exact integers so that it is exact whenever the true value is representable
 * (a centre on y = 0.25 really is on the slab's face). */
static double centre(int i, int res)
{
    return ((2.0 * i + 1.0) - res) / res;
}

typedef enum sample_kind {
    SAMPLE_CLOUD,
    SAMPLE_SMOKE,
    SAMPLE_SPHERE,
    SAMPLE_SLAB,
    SAMPLE_CUBE
} sample_kind;

static vdbs_status check_args(const char *name, int res, int *kind, vdbs_error *err)
{
    *kind = -1;
    for (int n = 0; name && vdbs_sample_names[n]; ++n)
        if (strcmp(name, vdbs_sample_names[n]) == 0)
            *kind = n;
    if (*kind < 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "sample: unknown sample volume \"%s\" (expected cloud, smoke, "
                              "sphere, slab or cube)",
                              name ? name : "(null)");
    if (res < 1 || res > 1024)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "sample: resolution %d is outside [1, 1024]",
                              res);
    return VDBS_OK;
}

vdbs_status vdbs_sample_fill(const char *name, int res, uint32_t seed, float *values,
                             vdbs_error *err)
{
    return vdbs_sample_fill_at(name, res, seed, -1.0, values, err);
}

vdbs_status vdbs_sample_fill_at(const char *name, int res, uint32_t seed, double time,
                                float *values, vdbs_error *err)
{
    int kind;
    vdbs_status st = check_args(name, res, &kind, err);
    if (st != VDBS_OK)
        return st;
    if (time >= 0.0 && kind != SAMPLE_SMOKE)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "sample: --time: only smoke moves");
    if (time > 1.0 || (time < 0.0 && time != -1.0) || time != time)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "sample: --time: expected a time in [0, 1]");
    if (!values)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "sample: no output array");

    cloud_params cp;
    smoke_params sp;
    cloud_init(&cp, seed);
    smoke_init(&sp, seed, time);
    const size_t n = (size_t)res;

    /* Every voxel is a pure function of its position: threads cannot change results. */
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < res; ++k) {
        const double z = centre(k, res);
        for (int j = 0; j < res; ++j) {
            const double y = centre(j, res);
            float *row = values + ((size_t)k * n + (size_t)j) * n;
            smoke_row srow = {0.0, 0.0, 1.0, 0.0};
            if (kind == SAMPLE_SMOKE)
                srow = smoke_row_at(&sp, y);
            for (int i = 0; i < res; ++i) {
                const double x = centre(i, res);
                float v = 0.0f;
                switch ((sample_kind)kind) {
                case SAMPLE_SPHERE: {
                    const double r = 0.8;
                    v = x * x + y * y + z * z <= r * r ? 1.0f : 0.0f;
                    break;
                }
                case SAMPLE_SLAB:
                    v = fabs(y) <= 0.25 ? 1.0f : 0.0f;
                    break;
                case SAMPLE_CUBE:
                    v = fabs(x) <= 0.6 && fabs(y) <= 0.6 && fabs(z) <= 0.6 ? 1.0f : 0.0f;
                    break;
                case SAMPLE_CLOUD:
                    v = cloud_value(&cp, x, y, z);
                    break;
                case SAMPLE_SMOKE:
                    v = smoke_value(&sp, &srow, x, y, z);
                    break;
                }
                row[i] = v;
            }
        }
    }
    return VDBS_OK;
}

void vdbs_sample_transform(int res, vdbio_transform *transform)
{
    const double h = 2.0 / res;
    memset(transform, 0, sizeof *transform);
    for (int r = 0; r < 3; ++r) {
        transform->m[r][r] = h;
        transform->m[r][3] = -1.0 + 0.5 * h;
    }
}

vdbs_status vdbs_sample_create(const char *name, int res, uint32_t seed, vdbio_density **out,
                               vdbs_error *err)
{
    return vdbs_sample_create_at(name, res, seed, -1.0, out, err);
}

vdbs_status vdbs_sample_create_at(const char *name, int res, uint32_t seed, double time,
                                  vdbio_density **out, vdbs_error *err)
{
    vdbio_transform xf;
    vdbs_status st;
    float *values;
    int kind;
    /* Check the arguments before allocating res^3 floats. */
    if ((st = check_args(name, res, &kind, err)) != VDBS_OK)
        return st;
    values = malloc((size_t)res * (size_t)res * (size_t)res * sizeof *values);
    if (!values)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "sample: out of memory for %d^3 voxels", res);
    st = vdbs_sample_fill_at(name, res, seed, time, values, err);
    if (st == VDBS_OK) {
        const int dims[3] = {res, res, res};
        const int origin[3] = {0, 0, 0};
        vdbs_sample_transform(res, &xf);
        st = vdbio_density_from_dense(values, dims, origin, &xf, "density", out, err);
    }
    free(values);
    return st;
}
