/* Principal-Ordinates Propagation (Elek et al., shared/papers/pop.md Secs. 4.2-4.3), shared by
 * C and GLSL: the parameter layout of one propagation grid and the gather that moves every
 * cell's light one cell in one iteration. Include after vs_common.h. Host side:
 * vdbscatter/pop.c.
 *
 * A grid has n0 x n1 x n2 cubic cells of world side h; axis 2 runs along the grid's principal
 * direction d (a sun's or sky ordinate's travel; any axis for the isotropic residuum). Cell
 * (i, j, k) is item (k n1 + j) n0 + i. Its state is a lobe per colour channel, L(w) =
 * L f_hg(w . d, a), plus what it has accumulated (the Neumann series sum_m L^m of L and of
 * L a, which map onto ms and ms_l1 exactly: DESIGN.md "The lit VDB"). The medium is one
 * sigma_t per cell (box-filtered, vdbscatter/medium.h) times the scene's RGB albedo.
 *
 * One iteration (Eqs. 2-6): each of the six neighbours src sends the part of its lobe that
 * falls in the solid angle towards dst, approximated as in Eq. 3 (front: the cone
 * theta < pi/4 about d; back: theta > 3 pi/4; each side: a quarter of the band between),
 * integrated with the HG CDF; the transmittance between the two cell centres counts
 * absorption only; the anisotropy decays by the mean-cosine law a exp(-sigma_s h (1 - g))
 * (exact for the first moment) or the paper's a g^(sigma_s h); the new anisotropy is the
 * energy-weighted mean of the arrivals. The six fractions of a lobe sum to 1, so without
 * absorption an iteration only moves energy (or lets it leave the grid). */
#ifndef VS_POP_H
#define VS_POP_H

/* Parameter words of one grid (`pop_params`: uints, floats as their bits). */
#define VS_POP_OFF_N 0      /* 3 uints: cells along axes 0, 1, 2 */
#define VS_POP_OFF_H 3      /* float: world side of a cell */
#define VS_POP_OFF_G 4      /* float: HG g of the medium */
#define VS_POP_OFF_ALBEDO 5 /* 3 floats: single-scattering albedo per channel */
#define VS_POP_OFF_DECAY 8  /* uint: VS_POP_DECAY_* */
#define VS_POP_OFF_KEEP_A 9 /* uint: 0: the isotropic residuum (anisotropy stays 0) */
#define VS_POP_OFF_CHORD 10 /* uint: 1: tally each crossing by the lobe's mean chord */
#define VS_POP_PARAM_WORDS 12
#define VS_POP_DECAY_MEAN_COSINE 0u
#define VS_POP_DECAY_PAPER 1u

/* State of a cell: floats per item and their meaning. */
#define VS_POP_STATE_L 0      /* 3: lobe magnitude per channel (the light in transit) */
#define VS_POP_STATE_A 3      /* 3: lobe anisotropy per channel */
#define VS_POP_STATE_ACC_L 6  /* 3: sum over iterations of L (fluence of scattered light) */
#define VS_POP_STATE_ACC_LA 9 /* 3: sum over iterations of L a */
#define VS_POP_STATE_WORDS 12

/* cos(pi / 4): the cone boundaries of Eq. 3. */
#define VS_POP_COS45 0.70710678118654752f

/* The fraction of an HG(a) lobe's power with mu <= m: C(m, a) = int_-1^m 2 pi f_hg(mu', a)
 * dmu' = (1 - a^2) / (2 a) (1 / sqrt(q) - 1 / (1 + a)) with q = 1 + a^2 - 2 a m (Eq. 1 times
 * 2 pi). That form divides by a and cancels for small a (5e-5 off at a = 0.002 in float);
 * rationalised it is (1 - a)(1 + m) / (sqrt(q) (1 + a + sqrt(q))), with q written
 * (1 - a)^2 + 2 a (1 - m): no division by a, no cancellation, exactly (1 + m) / 2 at a = 0. */
VS_FUNC float vs_pop_hg_cdf(float m, float a)
{
    float b = 1.0f - a;
    VS_PRECISE float r = vs_sqrt(vs_max(b * b + 2.0f * a * (1.0f - m), 0.0f));
    VS_PRECISE float den = r * (1.0f + a + r);
    float c = den > 0.0f ? b * (1.0f + m) / den : 0.0f;
    return vs_min(vs_max(c, 0.0f), 1.0f);
}

/* The mean chord through a cell, in cell sides, of light whose lobe has anisotropy a about a
 * grid axis: h for a beam along the axis, 4V/S = 2h/3 for isotropic light (Cauchy), linear in
 * |a| between. A crossing deposits fluence L times it (the faithful scheme counts h). */
VS_FUNC float vs_pop_chord(float a)
{
    return (2.0f + vs_min(vs_abs(a), 1.0f)) / 3.0f;
}

/* Fractions of an HG(a) lobe about d sent to the neighbour in front (+d), behind (-d) and to
 * each of the four sides (Eq. 3). */
VS_FUNC float vs_pop_front(float a)
{
    return 1.0f - vs_pop_hg_cdf(VS_POP_COS45, a);
}

VS_FUNC float vs_pop_back(float a)
{
    return vs_pop_hg_cdf(-VS_POP_COS45, a);
}

VS_FUNC float vs_pop_side(float a)
{
    return 0.25f * (vs_pop_hg_cdf(VS_POP_COS45, a) - vs_pop_hg_cdf(-VS_POP_COS45, a));
}

VS_FUNC int vs_pop_n(VS_DATA_PARAM(vs_uint, pop_params) int axis)
{
    return VS_INT(pop_params[VS_POP_OFF_N + axis]);
}

VS_FUNC float vs_pop_param(VS_DATA_PARAM(vs_uint, pop_params) int offset)
{
    return vs_word_float(pop_params[offset]);
}

/* The anisotropy left after a distance with optical thickness ts = sigma_s h of scattering. */
VS_FUNC float vs_pop_decay(float a, float ts, float g, vs_uint mode)
{
    if (mode == VS_POP_DECAY_PAPER)
        return ts > 0.0f ? a * vs_pow(vs_max(g, 0.0f), ts) : a;
    return a * vs_exp(-ts * (1.0f - g));
}

/* One iteration at cell `cell`: the new lobe from the six neighbours' lobes in pop_state_in,
 * and the accumulated sums carried forward, written to pop_state_out[out_base ..
 * out_base + VS_POP_STATE_WORDS). Returns
 * the new lobe's magnitude summed over the channels (the energy still in transit). */
VS_FUNC float vs_pop_gather(VS_DATA_PARAM(vs_uint, pop_params) VS_DATA_PARAM(float, pop_state_in)
                                VS_DATA_PARAM(float, pop_sigma) int cell,
                            VS_OUT_PARAM(float, pop_state_out) int out_base)
{
    int n0 = vs_pop_n(VS_DATA_ARG(pop_params) 0);
    int n1 = vs_pop_n(VS_DATA_ARG(pop_params) 1);
    int n2 = vs_pop_n(VS_DATA_ARG(pop_params) 2);
    float h = vs_pop_param(VS_DATA_ARG(pop_params) VS_POP_OFF_H);
    float g = vs_pop_param(VS_DATA_ARG(pop_params) VS_POP_OFF_G);
    vs_uint mode = pop_params[VS_POP_OFF_DECAY];
    int keep_a = pop_params[VS_POP_OFF_KEEP_A] != 0u ? 1 : 0;
    int i = cell % n0;
    int j = (cell / n0) % n1;
    int k = cell / (n0 * n1);
    float sigma_dst = pop_sigma[cell];
    float sum_l[3];
    float sum_la[3];
    float albedo[3];
    for (int c = 0; c < 3; ++c) {
        sum_l[c] = 0.0f;
        sum_la[c] = 0.0f;
        albedo[c] = vs_pop_param(VS_DATA_ARG(pop_params) VS_POP_OFF_ALBEDO + c);
    }
    /* Neighbour s: 0/1 at -/+ axis 0, 2/3 at -/+ axis 1 (sides), 4 behind dst (its light
     * moves forward into dst), 5 in front of dst (its light moves backward into dst). */
    for (int s = 0; s < 6; ++s) {
        int axis = s / 2;
        int step = (s % 2) == 0 ? -1 : 1;
        int at = axis == 0 ? i : (axis == 1 ? j : k);
        int size = axis == 0 ? n0 : (axis == 1 ? n1 : n2);
        if (at + step < 0 || at + step >= size)
            continue;
        int stride = axis == 0 ? 1 : (axis == 1 ? n0 : n0 * n1);
        int src = cell + step * stride;
        float sigma_mid = 0.5f * (pop_sigma[src] + sigma_dst);
        for (int c = 0; c < 3; ++c) {
            float l = pop_state_in[src * VS_POP_STATE_WORDS + VS_POP_STATE_L + c];
            if (!(l > 0.0f))
                continue;
            float a = pop_state_in[src * VS_POP_STATE_WORDS + VS_POP_STATE_A + c];
            float fraction = s < 4 ? vs_pop_side(a) : (s == 4 ? vs_pop_front(a) : vs_pop_back(a));
            float ts = sigma_mid * albedo[c] * h;
            float ta = sigma_mid * (1.0f - albedo[c]) * h;
            VS_PRECISE float dl = l * fraction * vs_exp(-ta);
            sum_l[c] += dl;
            sum_la[c] += keep_a != 0 ? dl * vs_pop_decay(a, ts, g, mode) : 0.0f;
        }
    }
    float total = 0.0f;
    int base = cell * VS_POP_STATE_WORDS;
    for (int c = 0; c < 3; ++c) {
        float a_new = sum_l[c] > 0.0f ? vs_min(vs_max(sum_la[c] / sum_l[c], -1.0f), 1.0f) : 0.0f;
        pop_state_out[out_base + VS_POP_STATE_L + c] = sum_l[c];
        pop_state_out[out_base + VS_POP_STATE_A + c] = a_new;
        float chord = pop_params[VS_POP_OFF_CHORD] != 0u ? vs_pop_chord(a_new) : 1.0f;
        pop_state_out[out_base + VS_POP_STATE_ACC_L + c] =
            pop_state_in[base + VS_POP_STATE_ACC_L + c] + sum_l[c] * chord;
        pop_state_out[out_base + VS_POP_STATE_ACC_LA + c] =
            pop_state_in[base + VS_POP_STATE_ACC_LA + c] + sum_l[c] * chord * a_new;
        total += sum_l[c];
    }
    return total;
}

#endif
