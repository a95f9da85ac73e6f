/* Henyey-Greenstein phase function, shared by C and GLSL (docs/design.md "Physical
 * conventions"). Include after vs_common.h.
 *
 * p(mu) = (1-g^2) / (4 pi (1+g^2-2 g mu)^1.5), evaluated in the cancellation-free form
 * (1-g)(1+g) / (4 pi ((1-g)^2 + 2 g (1-mu))^1.5) with 1-mu = |wi-wo|^2 / 2 taken from
 * the two propagation directions: 1 + g^2 - 2 g mu and mu itself lose every digit near
 * the forward peak in float (the naive form is 10% off there for g = 0.999), while
 * |wi-wo|^2 keeps them. That form is cancellation-free for g >= 0 only: for g < 0 the
 * peak is backwards, where (1-g)^2 + 2 g (1-mu) cancels, so negative g uses the mirror
 * image p(g, mu) = p(-g, -mu) with 1+mu = |wi+wo|^2 / 2. Finite for g = 0 exactly (the
 * isotropic 1/4pi) and |g| <= 0.999.
 */
#ifndef VS_PHASE_H
#define VS_PHASE_H

/* HG for g >= 0 as a function of s = 1 - mu (clamped to [0, 2]). */
VS_FUNC float vs_hg_forward(float g, float s)
{
    float x = vs_min(vs_max(s, 0.0f), 2.0f);
    float a = 1.0f - g;
    VS_PRECISE float d = a * a + 2.0f * g * x;
    VS_PRECISE float num = a * (1.0f + g) * VS_INV_4PI;
    return num / (d * vs_sqrt(d));
}

/* HG for any g given 1 - mu. For g < 0 near mu = -1 the digits of 1 + mu are already gone
 * in 1 - mu: prefer vs_hg_dirs, which measures them from the directions. */
VS_FUNC float vs_hg(float g, float one_minus_mu)
{
    return g >= 0.0f ? vs_hg_forward(g, one_minus_mu) : vs_hg_forward(-g, 2.0f - one_minus_mu);
}

/* |a - b|^2 / 2: 1 - a.b for unit vectors, without cancellation when a ~ b. */
VS_FUNC float vs_half_dist2(pnanovdb_vec3_t a, pnanovdb_vec3_t b)
{
    VS_PRECISE float dx = a.x - b.x;
    VS_PRECISE float dy = a.y - b.y;
    VS_PRECISE float dz = a.z - b.z;
    VS_PRECISE float s = dx * dx + dy * dy + dz * dz;
    return 0.5f * s;
}

/* 1 - wi.wo for unit vectors. */
VS_FUNC float vs_one_minus_cos(pnanovdb_vec3_t wi, pnanovdb_vec3_t wo)
{
    return vs_half_dist2(wi, wo);
}

/* HG for unit propagation directions wi (incident) and wo (outgoing). */
VS_FUNC float vs_hg_dirs(float g, pnanovdb_vec3_t wi, pnanovdb_vec3_t wo)
{
    if (g >= 0.0f)
        return vs_hg_forward(g, vs_half_dist2(wi, wo));
    return vs_hg_forward(-g, vs_half_dist2(wi, vs_vec3_scale(wo, -1.0f)));
}

/* Draws a scattering direction from HG(g) for a uniform u in [0, 1): the exact inverse of
 * the CDF, returned as (mu, sin_theta, 1 - mu), mu the cosine between the incident and
 * scattered propagation directions. The textbook inverse divides by g and cancels near
 * both peaks; with D = 1 - g + 2 g u it is
 *   1 - mu = 2 (1-g)^2 (1-u) (1+g u) / D^2,   1 + mu = 2 (1+g)^2 u (1-g+g u) / D^2,
 * both products of non-negative factors, so neither cancels (finite for g = 0 exactly and
 * |g| <= 0.999). mu is taken from the smaller of the two, sin_theta = sqrt((1-mu)(1+mu)),
 * and z keeps 1 - mu to full relative precision near the forward peak. mu(u) increases
 * with u. */
VS_FUNC pnanovdb_vec3_t vs_hg_sample(float g, float u)
{
    VS_PRECISE float d = 1.0f - g + 2.0f * g * u;
    VS_PRECISE float inv_d2 = 1.0f / (d * d);
    VS_PRECISE float omm = 2.0f * (1.0f - g) * (1.0f - g) * (1.0f - u) * (1.0f + g * u) * inv_d2;
    VS_PRECISE float opm = 2.0f * (1.0f + g) * (1.0f + g) * u * (1.0f - g + g * u) * inv_d2;
    omm = vs_min(vs_max(omm, 0.0f), 2.0f);
    opm = vs_min(vs_max(opm, 0.0f), 2.0f);
    float mu = omm <= 1.0f ? 1.0f - omm : opm - 1.0f;
    return vs_vec3(mu, vs_sqrt(omm * opm), omm);
}

/* HG lobes. A radiance lobe L f_hg(w . d, a) (w the propagation direction, d a unit axis,
 * |a| < 1) scattered by HG(g) gives the source S(wo) = L f_hg(wo . d, a g): HG's Legendre
 * coefficients are g^l, so convolving two HG phases multiplies them, giving HG(a g). Its
 * direction average is L / 4pi and its linear term 3 L a g d / 4pi (the first moment of
 * f_hg(., b) is b d), which is how a lobe maps onto the lit VDB's ms and ms_l1
 * (docs/design.md "The output grids"). Returns the anisotropy of the scattered lobe. */
VS_FUNC float vs_hg_lobe_scatter(float a, float g)
{
    return a * g;
}

#if !defined(PNANOVDB_GLSL)
/* Double-precision variants for the C-only Monte-Carlo reference (the float ones above are
 * the same formulas). VDBS_PI comes from the library's private base/vdbs_math.h; the include is
 * in angle brackets so that the shader embedder leaves it to the C preprocessor. */
#include <base/vdbs_math.h>

/* vs_hg_sample in double: *mu and *sin_theta for a uniform u in [0, 1). */
VS_FUNC void vs_hg_sample_d(double g, double u, double *mu, double *sin_theta)
{
    double d = 1.0 - g + 2.0 * g * u;
    double inv_d2 = 1.0 / (d * d);
    double omm = 2.0 * (1.0 - g) * (1.0 - g) * (1.0 - u) * (1.0 + g * u) * inv_d2;
    double opm = 2.0 * (1.0 + g) * (1.0 + g) * u * (1.0 - g + g * u) * inv_d2;
    omm = fmin(fmax(omm, 0.0), 2.0);
    opm = fmin(fmax(opm, 0.0), 2.0);
    *mu = omm <= 1.0 ? 1.0 - omm : opm - 1.0;
    *sin_theta = sqrt(omm * opm);
}

/* HG in double as a function of 1 - mu (clamped to [0, 2]), in the form of
 * vs_hg_forward for any g: cancellation-free for g >= 0; for g < 0 it loses relative
 * precision only at the backward peak, which double precision absorbs for |g| <= 0.999. */
VS_FUNC double vs_hg_eval_d(double g, double one_minus_mu)
{
    double a = 1.0 - g;
    double d = a * a + 2.0 * g * fmin(fmax(one_minus_mu, 0.0), 2.0);
    return a * (1.0 + g) / (4.0 * VDBS_PI * d * sqrt(d));
}
#endif

/* Sms toward wo for one colour channel from ms and its first-moment vector l1 (the
 * reconstruction of docs/lit-vdb.md, the render's and the radiance_view grid's):
 * n = l1/|l1|, b = min(|l1| / (3 ms), 0.999), Sms = 4 pi ms f_hg(wo.n, b); 0 where ms <= 0,
 * ms itself (isotropic) where l1 = 0. |l1| is computed on the largest component's scale
 * so that it neither overflows nor underflows. */
VS_FUNC float vs_ms_channel(float ms, float lx, float ly, float lz, pnanovdb_vec3_t wo)
{
    if (!(ms > 0.0f))
        return 0.0f;
    float m = vs_max(vs_abs(lx), vs_max(vs_abs(ly), vs_abs(lz)));
    if (!(m > 0.0f))
        return ms;
    pnanovdb_vec3_t u = vs_vec3(lx / m, ly / m, lz / m);
    float r = vs_sqrt(vs_vec3_dot(u, u));
    float len = m * r;
    float b = vs_min(len / (3.0f * ms), 0.999f);
    pnanovdb_vec3_t n = vs_vec3_scale(u, 1.0f / r);
    return 4.0f * VS_PI * ms * vs_hg_dirs(b, n, wo);
}

#endif
