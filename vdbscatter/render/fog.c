#include "vdbscatter/fog.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_phase.h"
#include "vs_fog.h"

/* 8-point Gauss-Legendre on [-1, 1]: nodes +-X and weights W. */
static const double GL8_X[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                0.9602898564975363};
static const double GL8_W[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                0.1012285362903763};

/* Panels of the table quadratures (8 points each). Four times as many change no entry by
 * more than 1.3e-4 relative for |g| <= 0.6 (the Gamma row next to lambda = 0 for g = -0.6;
 * 3.7e-5 everywhere else), well below the tables' interpolation error. */
#ifndef FOG_Q_PANELS
#define FOG_Q_PANELS 32
#endif
#ifndef FOG_PHI_PANELS
#define FOG_PHI_PANELS 32
#endif

/* The i-th of the 8 nodes of panel [a, b] and its weight. */
static void gl8_node(double a, double b, int i, double *x, double *w)
{
    double half = 0.5 * (b - a), mid = 0.5 * (a + b);
    double xi = i < 4 ? -GL8_X[3 - i] : GL8_X[i - 4];
    *x = mid + half * xi;
    *w = half * (i < 4 ? GL8_W[3 - i] : GL8_W[i - 4]);
}

/* HG in double from both 1 - mu and 1 + mu (each kept to full relative precision by the
 * caller): the cancellation-free form about the peak of the sign of g. */
static double hg_d(double g, double one_minus_mu, double one_plus_mu)
{
    double ag = fabs(g), x = g >= 0.0 ? one_minus_mu : one_plus_mu;
    double a = 1.0 - ag;
    double den = a * a + 2.0 * ag * x;
    return a * (1.0 + ag) / (4.0 * VDBS_PI * den * sqrt(den));
}

/* The scaled tail Gt(lambda, gamma) with c = u(gamma) = tan(pi/4 + gamma/2):
 *   Gt = int_0^inf 2 p(mu(c + q)) exp(-lambda q) / (1 + (c + q)^2) dq
 * (alpha = 2 atan(u) - pi/2, so mu = -sin(alpha) = (1 - u^2) / (1 + u^2)), integrated over
 * y = q / (q + L) in [0, 1) with L = 1 / (lambda + 1 / (1 + c)), the integrand's length
 * scale (1/lambda from the exponential, 1 + c from the Lorentzian). */
static double tail_exact(double g, double lambda, double c)
{
    double L = 1.0 / (lambda + 1.0 / (1.0 + c));
    double sum = 0.0;
    for (int p = 0; p < FOG_Q_PANELS; ++p) {
        for (int i = 0; i < 8; ++i) {
            double y, w;
            gl8_node((double)p / FOG_Q_PANELS, (double)(p + 1) / FOG_Q_PANELS, i, &y, &w);
            double q = L * y / (1.0 - y), dq = L / ((1.0 - y) * (1.0 - y));
            double u = c + q, inv = 1.0 / (1.0 + u * u);
            double p_mu = hg_d(g, 2.0 * u * u * inv, 2.0 * inv);
            sum += w * dq * 2.0 * p_mu * exp(-lambda * q) * inv;
        }
    }
    return sum;
}

/* The hemisphere kernel int_0^{2pi} max(0, cos(phi) cn + sin(phi) sn cos(theta)) dtheta. */
static double clamped_cos_ring(double phi, double cn, double sn)
{
    double A = cos(phi) * cn, B = sin(phi) * sn;
    if (B <= fabs(A))
        return A > 0.0 ? 2.0 * VDBS_PI * A : 0.0;
    double r = -A / B;
    return 2.0 * (A * acos(r) + B * sqrt(fmax(0.0, 1.0 - r * r)));
}

static vdbs_status check_medium(double sigma_t, double albedo, vdbs_error *err)
{
    if (!(sigma_t >= 0.0) || !isfinite(sigma_t))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "fog: sigma_t %g must be finite and >= 0",
                              sigma_t);
    if (!(albedo >= 0.0 && albedo <= 1.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "fog: albedo %g outside [0, 1]", albedo);
    return VDBS_OK;
}

static vdbs_status resolve_size(int *n, int def, const char *what, vdbs_error *err)
{
    if (*n == 0)
        *n = def;
    if (*n < VDBS_FOG_MIN_TABLE || *n > VDBS_FOG_MAX_TABLE)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "fog: %s %d outside [%d, %d]", what, *n,
                              VDBS_FOG_MIN_TABLE, VDBS_FOG_MAX_TABLE);
    return VDBS_OK;
}

static vdbs_status resolve_range(double *v, double def, const char *what, vdbs_error *err)
{
    if (*v == 0.0)
        *v = def;
    if (!(*v > 0.0 && *v <= 80.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "fog: %s %g outside (0, 80]", what, *v);
    return VDBS_OK;
}

/* The table's normaliser: the lookup's own vs_fog_e2, so that building and reading divide and
 * multiply by the same numbers. */
static double e2_d(double k)
{
    return (double)vs_fog_e2((float)k);
}

/* Gamma table: R = Gt / N on nodes (lambda_i, gamma_j), N = 2 / (1 + c) E(lambda (1 + c))
 * (shaders/vs_fog.h). At gamma = pi/2 (c infinite) R is its limit: Gt -> 2 p(-1) E(lambda c)
 * / c, so R -> p(-1) E(k) / e2(k) for k -> infinity, p(-1) / 0.995924, and p(-1) / e2(0) on
 * the row lambda = 0. */
static void build_gamma(const vdbs_fog_desc *desc, float *out)
{
    const int nl = desc->n_lambda, ng = desc->n_gamma;
    const double g = desc->g;
    const double p_back = hg_d(g, 2.0, 0.0);
#pragma omp parallel for schedule(dynamic, 4)
    for (int i = 0; i < nl; ++i) {
        double x = (double)i / (nl - 1), lambda = desc->lambda_max * x * x;
        for (int j = 0; j < ng; ++j) {
            if (j == ng - 1) {
                out[i * ng + j] = (float)(p_back / (i == 0 ? e2_d(0.0) : 0.995924));
                continue;
            }
            double gamma = -0.5 * VDBS_PI + VDBS_PI * j / (ng - 1);
            double c = tan(0.25 * VDBS_PI + 0.5 * gamma);
            double n = 2.0 / (1.0 + c) * e2_d(lambda * (1.0 + c));
            out[i * ng + j] = (float)(tail_exact(g, lambda, c) / n);
        }
    }
}

/* Lambert table: (1 + lambda) T(lambda, cn), T = int_0^pi Gt(lambda sin phi, phi - pi/2)
 * K(phi, cn) dphi, K the clamped-cosine ring (u(phi - pi/2) = tan(phi / 2)). K is C^1 in phi
 * (it behaves like (phi - phi_c)^{3/2} where the ring first meets the horizon), so a fixed
 * composite Gauss rule converges fast without cutting at phi_c. */
static vdbs_status build_lambert(const vdbs_fog_desc *desc, float *out, vdbs_error *err)
{
    const int nl = desc->lambert_n_lambda, nc = desc->lambert_n_cos;
    const int nphi = 8 * FOG_PHI_PANELS;
    double *phi = malloc(sizeof(double) * nphi), *wphi = malloc(sizeof(double) * nphi);
    if (!phi || !wphi) {
        free(phi);
        free(wphi);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "fog: out of memory");
    }
    /* phi = pi v^2, v uniform: the integrand changes like lambda phi log(lambda phi) near
     * phi = 0 (the rays that pass the light closely), which a uniform rule in phi resolves
     * poorly (3e-4 at lambda = 8 with 256 nodes). */
    for (int p = 0; p < FOG_PHI_PANELS; ++p) {
        for (int i = 0; i < 8; ++i) {
            double v, wv;
            gl8_node((double)p / FOG_PHI_PANELS, (double)(p + 1) / FOG_PHI_PANELS, i, &v, &wv);
            phi[8 * p + i] = VDBS_PI * v * v;
            wphi[8 * p + i] = 2.0 * VDBS_PI * v * wv;
        }
    }
    int failed = 0;
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < nl; ++i) {
        double x = (double)i / (nl - 1), lambda = desc->lambert_lambda_max * x * x;
        double *gt = malloc(sizeof(double) * nphi);
        if (!gt) {
#pragma omp atomic write
            failed = 1;
            continue;
        }
        for (int k = 0; k < nphi; ++k)
            gt[k] = tail_exact(desc->g, lambda * sin(phi[k]), tan(0.5 * phi[k]));
        for (int j = 0; j < nc; ++j) {
            double cn = -1.0 + 2.0 * j / (nc - 1), sn = sqrt(fmax(0.0, 1.0 - cn * cn));
            double sum = 0.0;
            for (int k = 0; k < nphi; ++k)
                sum += wphi[k] * gt[k] * clamped_cos_ring(phi[k], cn, sn);
            out[i * nc + j] = (float)((1.0 + lambda) * sum);
        }
        free(gt);
    }
    free(phi);
    free(wphi);
    if (failed)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "fog: out of memory");
    return VDBS_OK;
}

vdbs_status vdbs_fog_build(const vdbs_fog_desc *desc, vdbs_fog *fog, vdbs_error *err)
{
    memset(fog, 0, sizeof *fog);
    vdbs_fog_desc d = *desc;
    vdbs_status st = check_medium(d.sigma_t, d.albedo, err);
    if (st != VDBS_OK)
        return st;
    if (!(fabs(d.g) <= 0.999))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "fog: |g| = |%g| > 0.999", d.g);
    if ((st = resolve_size(&d.n_lambda, VDBS_FOG_DEFAULT_N_LAMBDA, "n_lambda", err)) ||
        (st = resolve_size(&d.n_gamma, VDBS_FOG_DEFAULT_N_GAMMA, "n_gamma", err)) ||
        (st = resolve_size(&d.lambert_n_lambda, VDBS_FOG_DEFAULT_LAMBERT_N_LAMBDA,
                           "lambert_n_lambda", err)) ||
        (st = resolve_size(&d.lambert_n_cos, VDBS_FOG_DEFAULT_LAMBERT_N_COS, "lambert_n_cos",
                           err)) ||
        (st = resolve_range(&d.lambda_max, VDBS_FOG_DEFAULT_LAMBDA_MAX, "lambda_max", err)) ||
        (st = resolve_range(&d.lambert_lambda_max, VDBS_FOG_DEFAULT_LAMBERT_LAMBDA_MAX,
                            "lambert_lambda_max", err)))
        return st;
    size_t gamma_floats = (size_t)d.n_lambda * (size_t)d.n_gamma;
    size_t lambert_floats = (size_t)d.lambert_n_lambda * (size_t)d.lambert_n_cos;
    size_t n = VS_FOG_OFF_TABLES + gamma_floats + lambert_floats;
    float *table = calloc(n, sizeof(float));
    if (!table)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "fog: out of memory for %zu floats", n);
    table[VS_FOG_OFF_SIGMA_T] = (float)d.sigma_t;
    table[VS_FOG_OFF_ALBEDO] = (float)d.albedo;
    table[VS_FOG_OFF_G] = (float)d.g;
    table[VS_FOG_OFF_LAMBDA_MAX] = (float)d.lambda_max;
    table[VS_FOG_OFF_N_LAMBDA] = (float)d.n_lambda;
    table[VS_FOG_OFF_N_GAMMA] = (float)d.n_gamma;
    table[VS_FOG_OFF_LAMBERT_LAMBDA_MAX] = (float)d.lambert_lambda_max;
    table[VS_FOG_OFF_LAMBERT_N_LAMBDA] = (float)d.lambert_n_lambda;
    table[VS_FOG_OFF_LAMBERT_N_COS] = (float)d.lambert_n_cos;
    build_gamma(&d, table + VS_FOG_OFF_TABLES);
    st = build_lambert(&d, table + VS_FOG_OFF_TABLES + gamma_floats, err);
    if (st != VDBS_OK) {
        free(table);
        return st;
    }
    fog->desc = d;
    fog->table = table;
    fog->table_floats = n;
    return VDBS_OK;
}

void vdbs_fog_free(vdbs_fog *fog)
{
    free(fog->table);
    memset(fog, 0, sizeof *fog);
}

vdbs_status vdbs_fog_set_medium(vdbs_fog *fog, double sigma_t, double albedo, vdbs_error *err)
{
    vdbs_status st = check_medium(sigma_t, albedo, err);
    if (st != VDBS_OK)
        return st;
    fog->desc.sigma_t = sigma_t;
    fog->desc.albedo = albedo;
    fog->table[VS_FOG_OFF_SIGMA_T] = (float)sigma_t;
    fog->table[VS_FOG_OFF_ALBEDO] = (float)albedo;
    return VDBS_OK;
}

static pnanovdb_vec3_t vec3_of(const double v[3])
{
    return vs_vec3((float)v[0], (float)v[1], (float)v[2]);
}

float vdbs_fog_point_span(const vdbs_fog *fog, const double o[3], const double d[3],
                          const double light[3], double intensity, double s_enter, double s0,
                          double s1)
{
    return vs_fog_point_span(fog->table, vec3_of(o), vec3_of(d), vec3_of(light), (float)intensity,
                             (float)s_enter, (float)s0, (float)s1);
}

float vdbs_fog_sun_span(const vdbs_fog *fog, const double o[3], const double d[3],
                        const double sun_dir[3], double irradiance, const double lo[3],
                        const double hi[3], double s_enter, double s0, double s1)
{
    return vs_fog_sun_span(fog->table, vec3_of(o), vec3_of(d), vec3_of(sun_dir), (float)irradiance,
                           vec3_of(lo), vec3_of(hi), (float)s_enter, (float)s0, (float)s1);
}

float vdbs_fog_surface_indirect(const vdbs_fog *fog, double l, double cos_phi_n, double intensity,
                                double reflectance)
{
    return vs_fog_surface_indirect(fog->table, (float)l, (float)cos_phi_n, (float)intensity,
                                   (float)reflectance);
}

float vdbs_fog_gamma(const vdbs_fog *fog, double lambda, double gamma)
{
    return vs_fog_gamma(fog->table, (float)lambda, (float)gamma);
}

/* ---- the oracle ---- */

/* Eq. 3's integrand at ray offset x = s - t from the light's foot point. */
static double march_integrand(const vdbs_fog_desc *desc, double h, double x, double view_tau)
{
    double r = sqrt(x * x + h * h);
    /* mu = -x / r; 1 -+ mu from whichever side keeps its digits. */
    double one_minus_mu = x >= 0.0 ? (r + x) / r : h * h / (r * (r - x));
    double one_plus_mu = x <= 0.0 ? (r - x) / r : h * h / (r * (r + x));
    return exp(-view_tau - desc->sigma_t * r) / (r * r) * hg_d(desc->g, one_minus_mu, one_plus_mu);
}

/* Integrates [xa, xb] (ray offsets on one side of the foot point, |xa| <= |xb|) outward
 * from xa in panels of width min((|x| + h) / 4, 1 / (4 sigma_t)). */
static double march_side(const vdbs_fog_desc *desc, double h, double t, double s_enter, double xa,
                         double xb)
{
    double sign = xb >= xa ? 1.0 : -1.0, sum = 0.0, x = xa;
    double cap = desc->sigma_t > 0.0 ? 0.25 / desc->sigma_t : INFINITY;
    while (sign * (xb - x) > 0.0) {
        double w = fmin(0.25 * (fabs(x) + h), cap);
        double xn = sign * (xb - x) <= w ? xb : x + sign * w;
        for (int i = 0; i < 8; ++i) {
            double xi, wi;
            gl8_node(x, xn, i, &xi, &wi);
            sum += wi * march_integrand(desc, h, xi, desc->sigma_t * (t + xi - s_enter));
        }
        x = xn;
    }
    return sign * sum; /* the weights of panels walked toward -x are negative */
}

double vdbs_fog_point_march(const vdbs_fog_desc *desc, const double o[3], const double d[3],
                            const double light[3], double intensity, double s_enter, double s0,
                            double s1)
{
    double m[3] = {light[0] - o[0], light[1] - o[1], light[2] - o[2]};
    double t = m[0] * d[0] + m[1] * d[1] + m[2] * d[2];
    double p[3] = {m[0] - t * d[0], m[1] - t * d[1], m[2] - t * d[2]};
    double h = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    if (desc->sigma_t > 0.0)
        s1 = fmin(s1, s_enter + 50.0 / desc->sigma_t);
    if (!(s1 > s0) || !(h > 0.0))
        return 0.0;
    double xa = s0 - t, xb = s1 - t, sum;
    if (xa < 0.0 && xb > 0.0)
        sum = march_side(desc, h, t, s_enter, 0.0, xa) + march_side(desc, h, t, s_enter, 0.0, xb);
    else if (xa >= 0.0)
        sum = march_side(desc, h, t, s_enter, xa, xb);
    else
        sum = march_side(desc, h, t, s_enter, xb, xa);
    return desc->albedo * desc->sigma_t * intensity * sum;
}
