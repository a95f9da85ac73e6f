/* Henyey-Greenstein phase function, shared by C and GLSL (DESIGN.md "Physical
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

#endif
