/* Illumination networks (Szirmay-Kalos et al., docs/methods/inet.md), shared by C and GLSL: the
 * parameter layout of one Jacobi sweep over the network and the new value of one slot.
 * Include after vs_common.h. Host side: vdbscatter/solvers/inet.c.
 *
 * The state holds the incoming scattered radiance I (3 channels) of every slot: slot p D + i is
 * the light that reaches particle p travelling along direction w_i; after the N D links come
 * the sinks, one per particle and direction with no particle after it (the light that leaves
 * the volume), so that every outgoing radiance of a sweep lands in exactly one slot and the
 * sweep's power balance reads off the state (inet.h vdbs_inet_balance). A slot takes the
 * outgoing radiance of its source particle q (its upstream neighbour; a sink's chain end) along
 * w_i, Eq. 2 of the paper with the phase sum balanced:
 *   L_q(w_i) = (1 - alpha) I_q(w_i) + E_q(w_i) + alpha a sum_d P_id I_q(w_d)
 * with alpha every particle's opacity, a the albedo, E the first scattering and P the balanced
 * D x D phase matrix (phasemat.h: every row and column sums to 1, so that a collision keeps its
 * power). A link without a source takes the radiance entering the volume (`inflow`: 0 for
 * scattered light, the sky's for the network's own first scattering in the white furnace).
 * Every slot of the new state depends only on the old one (Jacobi): the C path and the shader
 * compute it in the same order, so they agree to float rounding. */
#ifndef VS_INET_H
#define VS_INET_H

/* Parameter words (`inet_params`: uints, floats as their bits). */
#define VS_INET_OFF_PARTICLES 0  /* N */
#define VS_INET_OFF_DIRECTIONS 1 /* D */
#define VS_INET_OFF_OPACITY 2    /* float: alpha */
#define VS_INET_OFF_ALBEDO 3     /* 3 floats: a per channel */
#define VS_INET_OFF_INFLOW 6     /* 3 floats: radiance entering a link without a source */
#define VS_INET_OFF_EMISSION 9   /* 1: E is given (`inet_emission`); 0: none */
#define VS_INET_OFF_SINKS 10     /* sinks after the N D links */
#define VS_INET_PARAM_WORDS 11

/* `inet_source` (ints): per link slot its upstream particle or -1; per sink, from word N D,
 * its particle, and from word N D + sinks its direction. */

/* The source particle and direction of slot s; returns the particle, -1 for none. */
VS_FUNC int vs_inet_slot_source(VS_DATA_PARAM(int, inet_source) int s, int links, int sinks,
                                PNANOVDB_INOUT(int) dir, int directions)
{
    if (s < links) {
        PNANOVDB_DEREF(dir) = s % directions;
        return inet_source[s];
    }
    PNANOVDB_DEREF(dir) = inet_source[s + sinks];
    return inet_source[s];
}

/* The new radiance of slot s (3 channels) from the old state. */
VS_FUNC_HOT pnanovdb_vec3_t vs_inet_slot(VS_DATA_PARAM(vs_uint, inet_params)
                                             VS_DATA_PARAM(int, inet_source)
                                                 VS_DATA_PARAM(float, inet_phase)
                                                     VS_DATA_PARAM(float, inet_emission)
                                                         VS_DATA_PARAM(float, inet_in) int s)
{
    int n = VS_INT(inet_params[VS_INET_OFF_PARTICLES]);
    int dirs = VS_INT(inet_params[VS_INET_OFF_DIRECTIONS]);
    int sinks = VS_INT(inet_params[VS_INET_OFF_SINKS]);
    int i = 0;
    int q = vs_inet_slot_source(VS_DATA_ARG(inet_source) s, n * dirs, sinks, PNANOVDB_REF(i), dirs);
    if (q < 0)
        return vs_vec3(vs_word_float(inet_params[VS_INET_OFF_INFLOW]),
                       vs_word_float(inet_params[VS_INET_OFF_INFLOW + 1]),
                       vs_word_float(inet_params[VS_INET_OFF_INFLOW + 2]));
    float alpha = vs_word_float(inet_params[VS_INET_OFF_OPACITY]);
    /* The phase sum in one order on both paths (no lanes): they must round alike. */
    VS_PRECISE float r = 0.0f;
    VS_PRECISE float g = 0.0f;
    VS_PRECISE float b = 0.0f;
    int row = i * dirs;
    int base = q * dirs * 3;
    for (int d = 0; d < dirs; ++d) {
        float p = inet_phase[row + d];
        r += p * inet_in[base + 3 * d];
        g += p * inet_in[base + 3 * d + 1];
        b += p * inet_in[base + 3 * d + 2];
    }
    int at = base + 3 * i;
    VS_PRECISE float kr = alpha * vs_word_float(inet_params[VS_INET_OFF_ALBEDO]);
    VS_PRECISE float kg = alpha * vs_word_float(inet_params[VS_INET_OFF_ALBEDO + 1]);
    VS_PRECISE float kb = alpha * vs_word_float(inet_params[VS_INET_OFF_ALBEDO + 2]);
    VS_PRECISE float lr = (1.0f - alpha) * inet_in[at] + kr * r;
    VS_PRECISE float lg = (1.0f - alpha) * inet_in[at + 1] + kg * g;
    VS_PRECISE float lb = (1.0f - alpha) * inet_in[at + 2] + kb * b;
    if (inet_params[VS_INET_OFF_EMISSION] != 0u) {
        lr += inet_emission[at];
        lg += inet_emission[at + 1];
        lb += inet_emission[at + 2];
    }
    return vs_vec3(lr, lg, lb);
}

#endif
