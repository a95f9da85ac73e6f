/* Henyey-Greenstein phase function, shared by C and GLSL (DESIGN.md "Physical
 * conventions"). Include after vs_common.h.
 *
 * p(mu) = (1-g^2) / (4 pi (1+g^2-2 g mu)^1.5), evaluated in the cancellation-free form
 * (1-g)(1+g) / (4 pi ((1-g)^2 + 2 g (1-mu))^1.5) with 1-mu = |wi-wo|^2 / 2 taken from
 * the two propagation directions: 1 + g^2 - 2 g mu and mu itself lose every digit near
 * the forward peak in float (the naive form is 10% off there for g = 0.999), while
 * |wi-wo|^2 keeps them. Finite for g = 0 exactly (the isotropic 1/4pi) and |g| <= 0.999.
 */
#ifndef VS_PHASE_H
#define VS_PHASE_H

/* HG value for a given 1 - mu (clamped to its range [0, 2]). */
VS_FUNC float vs_hg(float g, float one_minus_mu)
{
    float omm = vs_min(vs_max(one_minus_mu, 0.0f), 2.0f);
    float a = 1.0f - g;
    VS_PRECISE float d = a * a + 2.0f * g * omm;
    VS_PRECISE float num = a * (1.0f + g) * VS_INV_4PI;
    return num / (d * vs_sqrt(d));
}

/* 1 - wi.wo for unit vectors, without cancellation: |wi - wo|^2 / 2. */
VS_FUNC float vs_one_minus_cos(pnanovdb_vec3_t wi, pnanovdb_vec3_t wo)
{
    VS_PRECISE float dx = wi.x - wo.x;
    VS_PRECISE float dy = wi.y - wo.y;
    VS_PRECISE float dz = wi.z - wo.z;
    VS_PRECISE float s = dx * dx + dy * dy + dz * dz;
    return 0.5f * s;
}

/* HG for unit propagation directions wi (incident) and wo (outgoing). */
VS_FUNC float vs_hg_dirs(float g, pnanovdb_vec3_t wi, pnanovdb_vec3_t wo)
{
    return vs_hg(g, vs_one_minus_cos(wi, wo));
}

#endif
