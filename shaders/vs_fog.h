/* Analytic single scattering in a homogeneous fog (Biri 2006, papers/single-scattering.md),
 * shared by C and GLSL. Include after vs_common.h and vs_phase.h. The table is a float array
 * (an SSBO `fog_data` in GLSL) written by vdbscatter/render/fog.c.
 *
 * Conventions (docs/design.md): HG of the cosine between propagation directions; a view ray is
 * x(s) = o + s d (d unit, s the distance from the camera); light arriving at the camera
 * travels along wo = -d. For a point light S, with t = (S - o).d, h the distance from S to
 * the ray's line and s - t = h tan(alpha) (Biri's change of variable), the light at x(s)
 * travels along wi = (x - S) / r, r = h / cos(alpha), so mu = wi.wo = -sin(alpha): Biri's
 * p(alpha + pi/2) is HG(mu = cos(alpha + pi/2)). alpha < 0 (the part of the ray between the
 * camera and the light's foot point) is forward scattering for a camera looking toward the
 * light.
 *
 * Eq. 3 with dx = h / cos^2(alpha) dalpha and x + r = t + h u(alpha),
 * u(alpha) = (1 + sin(alpha)) / cos(alpha):
 *   L = albedo sigma_t I / h * exp(-sigma_t t) * int p(-sin a) exp(-lambda u(a)) da,
 * lambda = sigma_t h. (Biri's Eq. 6 prints k_t lambda in the exponent with lambda = k_t h:
 * one k_t too many; his Eq. 7 prefactor k_t^2 Omega I / 4pi * e^{-k_t t} / (k_t h) is then
 * right for a phase normalised to 4pi, and his Eq. 14's e^{-k_t d} is a misprint of it.)
 *
 * Biri tabulates Gamma(lambda, gamma) = int_0^gamma; differences of it lose every digit on
 * spans beyond the light's foot point seen from a camera past it (exp(-sigma_t t) grows
 * like exp(sigma_t |t|) while the difference shrinks). The table therefore holds the
 * *scaled tail*
 *   Gt(lambda, gamma) = exp(lambda u(gamma)) int_gamma^{pi/2} p(-sin a) exp(-lambda u(a)) da,
 * bounded and smooth, so that a span is
 *   L(s0, s1) = albedo sigma_t I / h * [E(s0) Gt(gamma0) - E(s1) Gt(gamma1)],
 *   E(s) = exp(-sigma_t (s - s_enter + r(s)))  (the transmittance of the whole light path),
 * no huge factor anywhere. With c = u(gamma) = tan(pi/4 + gamma/2) and q = u(a) - c,
 *   Gt = int_0^inf 2 p exp(-lambda q) / (1 + (c + q)^2) dq.
 * Gt is stored divided by the same integral with p = 1 and (1 + c + q)^2 in the denominator,
 *   N(lambda, c) = 2 / (1 + c) * E(lambda (1 + c)),  E(k) = int_0^inf exp(-k x) / (1 + x)^2 dx
 * (= 1 - k e^k E1(k), vs_fog_e2), which has Gt's shape: both go like 2/c * E(lambda c) near
 * gamma = pi/2, where Gt depends on lambda and pi/2 - gamma only through their ratio (no
 * bilinear table resolves that corner), and like 1/lambda for large lambda. The stored
 * ratio is then a smooth, bounded weighted mean of p (p(-1) / 0.995924 at gamma = pi/2).
 * Biri's Gamma itself is
 * Gamma(gamma) = exp(-lambda) Gt(0) - exp(-lambda u(gamma)) Gt(gamma) (vs_fog_gamma).
 */
#ifndef VS_FOG_H
#define VS_FOG_H

#if defined(PNANOVDB_GLSL)
#define vs_fog_sin sin
#define vs_fog_cos cos
#define vs_fog_log log
#else
#define vs_fog_sin sinf
#define vs_fog_cos cosf
#define vs_fog_log logf
#endif

/* Header floats. */
#define VS_FOG_OFF_SIGMA_T 0
#define VS_FOG_OFF_ALBEDO 1
#define VS_FOG_OFF_G 2
/* The Gamma table's lambda range [0, lambda_max] and its size: n_lambda rows of n_gamma
 * values, gamma uniform over [-pi/2, pi/2], gamma fastest. Rows are uniform in
 * sqrt(lambda / lambda_max) (row i at lambda_max (i / (n_lambda - 1))^2): the tables change
 * fastest near lambda = 0 (for g < 0 the back peak near gamma = pi/2 is cut off by
 * exp(-lambda u) once lambda reaches its width), slowly for large lambda. */
#define VS_FOG_OFF_LAMBDA_MAX 3
#define VS_FOG_OFF_N_LAMBDA 4
#define VS_FOG_OFF_N_GAMMA 5
/* The Lambert table's lambda range [0, lambert_lambda_max] and size: n rows (lambda, uniform
 * in sqrt(lambda) as above) of n_cos values, cos(phi_n) uniform over [-1, 1], cos fastest. */
#define VS_FOG_OFF_LAMBERT_LAMBDA_MAX 6
#define VS_FOG_OFF_LAMBERT_N_LAMBDA 7
#define VS_FOG_OFF_LAMBERT_N_COS 8
/* The Gamma table starts here; the Lambert table follows it (vs_fog_lambert_base). */
#define VS_FOG_OFF_TABLES 16
#define VS_FOG_HEADER_SIZE 16

VS_FUNC float vs_fog_sigma_t(VS_DATA_ONLY(float, fog_data))
{
    return fog_data[VS_FOG_OFF_SIGMA_T];
}

VS_FUNC float vs_fog_albedo(VS_DATA_ONLY(float, fog_data))
{
    return fog_data[VS_FOG_OFF_ALBEDO];
}

VS_FUNC float vs_fog_g(VS_DATA_ONLY(float, fog_data))
{
    return fog_data[VS_FOG_OFF_G];
}

VS_FUNC int vs_fog_lambert_base(VS_DATA_ONLY(float, fog_data))
{
    return VS_FOG_OFF_TABLES +
           VS_INT(fog_data[VS_FOG_OFF_N_LAMBDA]) * VS_INT(fog_data[VS_FOG_OFF_N_GAMMA]);
}

/* Bilinear interpolation of a table of n_slow rows of n_fast floats starting at `base`, at
 * continuous node coordinates (x, y) (clamped to the table), the same arithmetic in C and
 * GLSL (no samplers: they would filter in 8-bit fixed point). */
VS_FUNC float vs_fog_bilinear(VS_DATA_PARAM(float, fog_data) int base, int n_fast, int n_slow,
                              float x, float y)
{
    float cx = vs_min(vs_max(x, 0.0f), VS_FLOAT(n_fast - 1));
    float cy = vs_min(vs_max(y, 0.0f), VS_FLOAT(n_slow - 1));
    int i = VS_INT(cx);
    int j = VS_INT(cy);
    if (i > n_fast - 2)
        i = n_fast - 2;
    if (j > n_slow - 2)
        j = n_slow - 2;
    float fx = cx - VS_FLOAT(i);
    float fy = cy - VS_FLOAT(j);
    int k = base + j * n_fast + i;
    float v00 = fog_data[k];
    float v10 = fog_data[k + 1];
    float v01 = fog_data[k + n_fast];
    float v11 = fog_data[k + n_fast + 1];
    float lo = v00 + fx * (v10 - v00);
    float hi = v01 + fx * (v11 - v01);
    return lo + fy * (hi - lo);
}

/* E(k) = int_0^inf exp(-k x) / (1 + x)^2 dx = 1 - k e^k E1(k) for k >= 0, from Abramowitz and
 * Stegun's E1 approximations 5.1.53 (k <= 1, |error| < 2e-7 in E1) and 5.1.56 (k > 1, written
 * as one rational function so that 1 - k e^k E1 does not cancel; relative error < 5e-5 k,
 * but smooth: it only normalises the table, and build and lookup use the same formula). */
VS_FUNC float vs_fog_e2(float k)
{
    if (k > 1.0f)
        return (0.995924f + 1.430913f / k) / (k + 3.330657f + 1.681534f / k);
    if (!(k > 1.0e-30f))
        return 1.0f;
    float poly = -0.57721566f +
                 k * (0.99999193f + k * (-0.24991055f +
                                         k * (0.05519968f + k * (-0.00976004f + k * 0.00107857f))));
    return 1.0f - k * vs_exp(k) * (poly - vs_fog_log(k));
}

/* The scaled tail Gt(lambda, gamma) at gamma = pi/2 - a, given a = pi/2 - gamma in [0, pi]
 * and c = u(gamma) (both passed in so that the caller keeps their digits near
 * gamma = pi/2). Beyond lambda_max the table's last row is used (see fog.h). */
VS_FUNC float vs_fog_tail(VS_DATA_PARAM(float, fog_data) float lambda, float a, float c)
{
    int n_lambda = VS_INT(fog_data[VS_FOG_OFF_N_LAMBDA]);
    int n_gamma = VS_INT(fog_data[VS_FOG_OFF_N_GAMMA]);
    float lambda_max = fog_data[VS_FOG_OFF_LAMBDA_MAX];
    float x = (VS_PI - a) * (VS_FLOAT(n_gamma - 1) / VS_PI);
    float y = vs_sqrt(lambda / lambda_max) * VS_FLOAT(n_lambda - 1);
    float ratio = vs_fog_bilinear(VS_DATA_ARG(fog_data) VS_FOG_OFF_TABLES, n_gamma, n_lambda, x, y);
    return ratio * 2.0f / (1.0f + c) * vs_fog_e2(lambda * (1.0f + c));
}

/* Biri's Gamma(lambda, gamma) (Eq. 6 with the exponent lambda u(alpha)), for gamma in
 * [-pi/2, pi/2]: for plotting and checks; the span functions use the scaled tail. */
VS_FUNC float vs_fog_gamma(VS_DATA_PARAM(float, fog_data) float lambda, float gamma)
{
    float s = vs_fog_sin(gamma);
    float c = vs_fog_cos(gamma);
    float whole = vs_exp(-lambda) * vs_fog_tail(VS_DATA_ARG(fog_data) lambda, 0.5f * VS_PI, 1.0f);
    if (!(c > 0.0f))
        return gamma > 0.0f ? whole
                            : whole - vs_fog_tail(VS_DATA_ARG(fog_data) lambda, VS_PI, 0.0f);
    float u = (1.0f + s) / c;
    return whole -
           vs_exp(-lambda * u) * vs_fog_tail(VS_DATA_ARG(fog_data) lambda, 0.5f * VS_PI - gamma, u);
}

/* E(s) Gt(gamma(s)) at ray offset x = s - t from the light's foot point: the point-light
 * antiderivative (up to the factor albedo sigma_t I / h). path_tau is sigma_t (s - s_enter),
 * the view ray's optical depth up to s. */
VS_FUNC float vs_fog_point_term(VS_DATA_PARAM(float, fog_data) float sigma_t, float h, float x,
                                float path_tau)
{
    float r = vs_sqrt(x * x + h * h);
    float tau = path_tau + sigma_t * r;
    if (!(tau < 87.0f))
        return 0.0f; /* exp underflows float: the antiderivative is 0 there */
    float a = vs_atan2(h, x);
    /* c = u(gamma) = (r + x) / h without cancellation for x < 0. */
    float c = x >= 0.0f ? (r + x) / h : h / (r - x);
    return vs_exp(-tau) * vs_fog_tail(VS_DATA_ARG(fog_data) sigma_t * h, a, c);
}

/* In-scattered radiance toward the camera from a point light of intensity `intensity`
 * (W/sr) at `light`, along the lit span [s0, s1] of the view ray o + s d (d unit),
 * s_enter <= s0 the distance at which the ray enters the fog (0 for a camera inside it):
 * the view transmittance to s is exp(-sigma_t (s - s_enter)). The light's path to every
 * point of the span is assumed to lie in the fog (a point light inside a convex fog
 * region, or fog everywhere). Spans add: the sum over a ray's lit spans is the shadowed
 * result (Biri Eq. 14). s1 may be VS_T_INFINITE. */
VS_FUNC float vs_fog_point_span(VS_DATA_PARAM(float, fog_data) pnanovdb_vec3_t o, pnanovdb_vec3_t d,
                                pnanovdb_vec3_t light, float intensity, float s_enter, float s0,
                                float s1)
{
    float sigma_t = vs_fog_sigma_t(VS_DATA_ONLY_ARG(fog_data));
    if (!(s1 > s0) || !(sigma_t > 0.0f))
        return 0.0f;
    pnanovdb_vec3_t m = vs_vec3(light.x - o.x, light.y - o.y, light.z - o.z);
    float t = vs_vec3_dot(m, d);
    pnanovdb_vec3_t perp = vs_vec3_madd(m, d, -t);
    /* A ray through the light itself diverges (1/r^2): keep h off zero so the result stays
     * finite (and large). */
    float h = vs_max(vs_sqrt(vs_vec3_dot(perp, perp)), 1.0e-6f * (vs_abs(t) + 1.0e-20f));
    float e0 =
        vs_fog_point_term(VS_DATA_ARG(fog_data) sigma_t, h, s0 - t, sigma_t * (s0 - s_enter));
    float e1 =
        vs_fog_point_term(VS_DATA_ARG(fog_data) sigma_t, h, s1 - t, sigma_t * (s1 - s_enter));
    return vs_fog_albedo(VS_DATA_ONLY_ARG(fog_data)) * sigma_t * intensity / h *
           vs_max(e0 - e1, 0.0f);
}

/* len * (exp(-A) - exp(-B)) / (B - A): the integral of exp(-tau) over a segment of length len
 * along which the optical depth tau goes linearly from A to B, without the cancellation of
 * the difference when B ~ A (series of (1 - exp(-x)) / x below |x| = 0.03, error < 1e-8). */
VS_FUNC float vs_fog_exp_segment(float A, float B, float len)
{
    float x = B - A;
    if (vs_abs(x) < 0.03f)
        return len * vs_exp(-A) * (1.0f - x * (0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f))));
    return len * (vs_exp(-A) - vs_exp(-B)) / x;
}

/* The slab distance of one axis toward the sun along the view ray, as base + slope s
 * (w the direction toward the sun, component wc; o, d the ray's components). */
VS_FUNC float vs_fog_slab_base(float wc, float oc, float lo, float hi)
{
    return wc > 0.0f ? (hi - oc) / wc : (wc < 0.0f ? (lo - oc) / wc : VS_T_INFINITE);
}

VS_FUNC float vs_fog_slab_slope(float wc, float dc)
{
    return wc != 0.0f ? -dc / wc : 0.0f;
}

/* In-scattered radiance toward the camera from a sun (`sun_dir` the unit direction the light
 * travels, `irradiance` in W/m^2 on a surface facing it) along the lit span [s0, s1] of the
 * view ray o + s d inside the fog box [box_lo, box_hi] (s_enter as for vs_fog_point_span).
 * Sunlight reaching x(s) crossed the box from its boundary toward the sun, distance D(s);
 * D is the minimum of the three slabs' distances, each linear in s, so it is linear
 * between the points where two slabs cross: the span is cut there and each piece's
 * exp(-sigma_t (s - s_enter + D(s))) is integrated in closed form. The phase is constant:
 * HG(g, sun_dir . (-d)). */
VS_FUNC float vs_fog_sun_span(VS_DATA_PARAM(float, fog_data) pnanovdb_vec3_t o, pnanovdb_vec3_t d,
                              pnanovdb_vec3_t sun_dir, float irradiance, pnanovdb_vec3_t box_lo,
                              pnanovdb_vec3_t box_hi, float s_enter, float s0, float s1)
{
    float sigma_t = vs_fog_sigma_t(VS_DATA_ONLY_ARG(fog_data));
    if (!(s1 > s0) || !(sigma_t > 0.0f))
        return 0.0f;
    pnanovdb_vec3_t w = vs_vec3_scale(sun_dir, -1.0f);
    float base[3];
    float slope[3];
    base[0] = vs_fog_slab_base(w.x, o.x, box_lo.x, box_hi.x);
    base[1] = vs_fog_slab_base(w.y, o.y, box_lo.y, box_hi.y);
    base[2] = vs_fog_slab_base(w.z, o.z, box_lo.z, box_hi.z);
    slope[0] = vs_fog_slab_slope(w.x, d.x);
    slope[1] = vs_fog_slab_slope(w.y, d.y);
    slope[2] = vs_fog_slab_slope(w.z, d.z);
    /* D is concave: walk its pieces from s0, each time to the earliest crossing with a slab
     * of smaller slope, which then becomes the active one (at most three pieces, the slope
     * decreasing strictly; the active slab is carried over rather than re-chosen, so that
     * rounding at a crossing cannot stall the walk). */
    int k = 0;
    float best = base[0] + slope[0] * s0;
    for (int i = 1; i < 3; ++i) {
        float v = base[i] + slope[i] * s0;
        if (v < best || (v == best && slope[i] < slope[k])) {
            k = i;
            best = v;
        }
    }
    float sum = 0.0f;
    float s = s0;
    for (int piece = 0; piece < 3; ++piece) {
        float s_next = s1;
        int k_next = k;
        for (int i = 0; i < 3; ++i) {
            if (slope[i] < slope[k] && base[i] < VS_T_INFINITE) {
                float sc = (base[i] - base[k]) / (slope[k] - slope[i]);
                if (sc < s_next) {
                    s_next = vs_max(sc, s);
                    k_next = i;
                }
            }
        }
        float tau_a = sigma_t * ((s - s_enter) + vs_max(base[k] + slope[k] * s, 0.0f));
        float tau_b = sigma_t * ((s_next - s_enter) + vs_max(base[k] + slope[k] * s_next, 0.0f));
        sum += vs_fog_exp_segment(tau_a, tau_b, s_next - s);
        s = s_next;
        k = k_next;
        if (!(s < s1))
            break;
    }
    float phase =
        vs_hg_dirs(vs_fog_g(VS_DATA_ONLY_ARG(fog_data)), sun_dir, vs_vec3_scale(d, -1.0f));
    return vs_fog_albedo(VS_DATA_ONLY_ARG(fog_data)) * sigma_t * irradiance * phase * sum;
}

/* Radiance leaving a Lambertian surface point (diffuse reflectance `reflectance`, BRDF
 * reflectance / pi) lit by the fog's single scattering of a point light of intensity
 * `intensity` at distance l (Biri Sec. III.C, Eq. 8 with d = infinity), cos_phi_n the cosine
 * between the surface normal and the direction from the point to the light. Not attenuated
 * toward the camera, and without the direct light.
 *
 * Biri's Eq. 10 integrates the *signed* cosine u.n over the whole sphere, which subtracts
 * the fog behind the surface and gives cos(phi_n) times a function of lambda; clamped at 0
 * it would leave a surface facing away from the light black, although the lit fog in front
 * of it shines on it. The table therefore holds the exact Eq. 8 with the clamped cosine
 * max(u.n, 0) over the hemisphere above the surface, a function of (lambda = sigma_t l,
 * cos phi_n), positive for every orientation:
 *   L = reflectance / pi * albedo sigma_t I exp(-sigma_t l) / l * T(lambda, cos phi_n),
 * stored as (1 + lambda) T, which is nearly flat in lambda. */
VS_FUNC float vs_fog_surface_indirect(VS_DATA_PARAM(float, fog_data) float l, float cos_phi_n,
                                      float intensity, float reflectance)
{
    float sigma_t = vs_fog_sigma_t(VS_DATA_ONLY_ARG(fog_data));
    if (!(sigma_t > 0.0f) || !(l > 0.0f))
        return 0.0f;
    float lambda = sigma_t * l;
    if (!(lambda < 87.0f))
        return 0.0f;
    int n_lambda = VS_INT(fog_data[VS_FOG_OFF_LAMBERT_N_LAMBDA]);
    int n_cos = VS_INT(fog_data[VS_FOG_OFF_LAMBERT_N_COS]);
    float lambda_max = fog_data[VS_FOG_OFF_LAMBERT_LAMBDA_MAX];
    float x = (cos_phi_n + 1.0f) * (0.5f * VS_FLOAT(n_cos - 1));
    float y = vs_sqrt(lambda / lambda_max) * VS_FLOAT(n_lambda - 1);
    float scaled =
        vs_fog_bilinear(VS_DATA_ARG(fog_data) vs_fog_lambert_base(VS_DATA_ONLY_ARG(fog_data)),
                        n_cos, n_lambda, x, y);
    float t = scaled / (1.0f + lambda);
    return reflectance * (1.0f / VS_PI) * vs_fog_albedo(VS_DATA_ONLY_ARG(fog_data)) * sigma_t *
           intensity * vs_exp(-lambda) / l * t;
}

#endif
