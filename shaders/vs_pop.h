/* Principal-Ordinates Propagation (Elek et al. 2014, Secs. 4.2-4.3), shared by
 * C and GLSL: the parameter layout of one propagation grid and the gather that moves every
 * cell's light one cell in one iteration. Include after vs_common.h. Host side:
 * vdbscatter/solvers/pop.c.
 *
 * A grid has n0 x n1 x n2 cubic cells of world side h; axis 2 runs along the grid's principal
 * direction d (a sun's or sky ordinate's travel; any axis for the isotropic residuum). Cell
 * (i, j, k) is item (k n1 + j) n0 + i. Its state is a lobe per colour channel, L(w) =
 * L f_hg(w . d, a), plus what it has accumulated (the Neumann series sum_m L^m of L and of
 * L a, which map onto ms and ms_l1 exactly: docs/design.md "The output grids"). The medium is one
 * sigma_t per cell (box-filtered, vdbscatter/medium.h) times the scene's RGB albedo.
 *
 * One iteration (Eqs. 2-6): each of the six neighbours src sends the part of its lobe that
 * falls in the solid angle towards dst, approximated as in Eq. 3 (front: the cone
 * theta < pi/4 about d; back: theta > 3 pi/4; each side: a quarter of the band between),
 * integrated with the HG CDF; the transmittance between the two cell centres counts
 * absorption only; the anisotropy decays by the mean-cosine law a exp(-sigma_s h (1 - g))
 * (exact for the first moment) or the paper's a g^(sigma_s h); the new anisotropy is the
 * energy-weighted mean of the arrivals. The six fractions of a lobe sum to 1, so without
 * absorption an iteration only moves energy (or lets it leave the grid).
 *
 * Radial grids (Sec. 6; point lights, and the camera's importance) run the same gather over
 * texels of an angular map times shells: the principal direction of a cell is radial, the
 * four angular neighbours take the sides, and what moves between cells of unequal size is the
 * lobe's power (vs_pop_radial_source). */
#ifndef VS_POP_H
#define VS_POP_H

/* Parameter words of one grid (`pop_params`: uints, floats as their bits). */
#define VS_POP_OFF_N 0      /* 3 uints: cells along axes 0, 1, 2 */
#define VS_POP_OFF_H 3      /* float: rectilinear: world side of a cell */
#define VS_POP_OFF_G 4      /* float: HG g of the medium */
#define VS_POP_OFF_ALBEDO 5 /* 3 floats: single-scattering albedo per channel */
#define VS_POP_OFF_DECAY 8  /* uint: VS_POP_DECAY_* */
#define VS_POP_OFF_KEEP_A 9 /* uint: 0: the isotropic residuum (anisotropy stays 0) */
#define VS_POP_OFF_CHORD 10 /* uint: 1: tally each crossing by the lobe's mean chord */
#define VS_POP_OFF_KIND 11  /* uint: VS_POP_RECTILINEAR or VS_POP_RADIAL */
/* Radial grids (Sec. 6): axes 0 and 1 are texels of an angular map around a centre, axis 2
 * the shells outwards. */
/* uint: 1: octahedral map over the whole sphere (edges fold, light moving inwards from shell 0
 * passes the centre into the antipodal texel); 0: a frustum, open on every side. */
#define VS_POP_OFF_WRAP 12
#define VS_POP_OFF_RADII 13  /* uint: word offset of the n2 + 1 shell radii (floats) */
#define VS_POP_OFF_TEXELS 14 /* uint: word offset of n0 n1 texel records */
/* uint: 1: the flux-conserving scale (vs_pop_radial_source); 0: none (what the energy test
 * shows to be wrong). */
#define VS_POP_OFF_COMPENSATE 15
#define VS_POP_PARAM_WORDS 16 /* the header; radial tables follow it */
#define VS_POP_RECTILINEAR 0u
#define VS_POP_RADIAL 1u
#define VS_POP_DECAY_MEAN_COSINE 0u
#define VS_POP_DECAY_PAPER 1u
/* Texel record: its solid angle, the unit direction of its centre and the share of its sides'
 * light that stays (vs_pop_radial_source; a missing neighbour of an open map counts as the
 * texel itself). */
#define VS_POP_TEXEL_OMEGA 0
#define VS_POP_TEXEL_DIR 1
#define VS_POP_TEXEL_STAY 4
#define VS_POP_TEXEL_WORDS 5
/* Which fraction of the source's lobe a transfer carries. */
#define VS_POP_SEND_SIDE 0
#define VS_POP_SEND_FRONT 1
#define VS_POP_SEND_BACK 2

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

/* ---- rectilinear grids ---- */

/* Neighbour s of cell (i, j, k): 0/1 at -/+ axis 0, 2/3 at -/+ axis 1 (sides), 4 behind
 * (its light moves forward into the cell), 5 in front (its light moves backward). Returns
 * the source cell, or -1 where the grid ends, and what it sends. */
VS_FUNC int vs_pop_rect_source(VS_DATA_PARAM(vs_uint, pop_params) int i, int j, int k, int s,
                               PNANOVDB_INOUT(int) send)
{
    int n0 = vs_pop_n(VS_DATA_ARG(pop_params) 0);
    int n1 = vs_pop_n(VS_DATA_ARG(pop_params) 1);
    int axis = s / 2;
    int step = (s % 2) == 0 ? -1 : 1;
    int at = axis == 0 ? i : (axis == 1 ? j : k);
    int size = vs_pop_n(VS_DATA_ARG(pop_params) axis);
    PNANOVDB_DEREF(send) =
        s < 4 ? VS_POP_SEND_SIDE : (s == 4 ? VS_POP_SEND_FRONT : VS_POP_SEND_BACK);
    if (at + step < 0 || at + step >= size)
        return -1;
    int stride = axis == 0 ? 1 : (axis == 1 ? n0 : n0 * n1);
    return (k * n1 + j) * n0 + i + step * stride;
}

/* ---- radial grids ---- */

VS_FUNC float vs_pop_radius(VS_DATA_PARAM(vs_uint, pop_params) int k)
{
    return vs_word_float(pop_params[pop_params[VS_POP_OFF_RADII] + VS_UINT(k)]);
}

VS_FUNC float vs_pop_texel(VS_DATA_PARAM(vs_uint, pop_params) int texel, int word)
{
    return vs_word_float(
        pop_params[pop_params[VS_POP_OFF_TEXELS] + VS_UINT(texel * VS_POP_TEXEL_WORDS + word)]);
}

/* A radial cell's volume per unit radial length, Omega (r1^3 - r0^3) / (3 (r1 - r0)), written
 * without the difference: the mean area of the shell section through which its light's power
 * flows. A lobe of magnitude L (fluence per crossing, as on rectilinear grids) carries the
 * power L A(cell). */
VS_FUNC float vs_pop_radial_area(VS_DATA_PARAM(vs_uint, pop_params) int texel, int k)
{
    float r0 = vs_pop_radius(VS_DATA_ARG(pop_params) k);
    float r1 = vs_pop_radius(VS_DATA_ARG(pop_params) k + 1);
    return vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_OMEGA) *
           (r1 * r1 + r1 * r0 + r0 * r0) / 3.0f;
}

/* The centroid radius of shell k: 3/4 (r1^4 - r0^4) / (r1^3 - r0^3), without the differences. */
VS_FUNC float vs_pop_radial_centre(VS_DATA_PARAM(vs_uint, pop_params) int k)
{
    float r0 = vs_pop_radius(VS_DATA_ARG(pop_params) k);
    float r1 = vs_pop_radius(VS_DATA_ARG(pop_params) k + 1);
    return 0.75f * (r1 + r0) * (r1 * r1 + r0 * r0) / (r1 * r1 + r1 * r0 + r0 * r0);
}

/* Texel (i + di, j + dj) of an n0 x n1 map (one of di, dj non-zero), or -1 off an open map.
 * The octahedral map's square folds onto itself over each edge, mirrored: the direction at
 * (x, -1) is the one at (-x, -1), so the neighbour below texel (i, 0) is (n - 1 - i, 0). */
VS_FUNC int vs_pop_texel_step(VS_DATA_PARAM(vs_uint, pop_params) int i, int j, int di, int dj)
{
    int n0 = vs_pop_n(VS_DATA_ARG(pop_params) 0);
    int n1 = vs_pop_n(VS_DATA_ARG(pop_params) 1);
    int ii = i + di, jj = j + dj;
    int inside = ii >= 0 && ii < n0 && jj >= 0 && jj < n1 ? 1 : 0;
    if (inside == 0 && pop_params[VS_POP_OFF_WRAP] == 0u)
        return -1;
    if (ii < 0 || ii >= n0) {
        ii = i;
        jj = n1 - 1 - j;
    } else if (jj < 0 || jj >= n1) {
        jj = j;
        ii = n0 - 1 - i;
    }
    return jj * n0 + ii;
}

/* The octahedral texel of the opposite direction. With x = a / n, a = 2 i + 1 - n, both
 * hemispheres give the antipode (-sign(x) (1 - |y|), -sign(y) (1 - |x|)), a texel centre again
 * for even n. */
VS_FUNC int vs_pop_antipode(VS_DATA_PARAM(vs_uint, pop_params) int i, int j)
{
    int n = vs_pop_n(VS_DATA_ARG(pop_params) 0);
    int a = 2 * i + 1 - n, b = 2 * j + 1 - n;
    int a2 = (a < 0 ? 1 : -1) * (n - (b < 0 ? -b : b));
    int b2 = (b < 0 ? 1 : -1) * (n - (a < 0 ? -a : a));
    return ((b2 + n - 1) / 2) * n + (a2 + n - 1) / 2;
}

/* Neighbour s of radial cell (i, j, k), numbered as vs_pop_rect_source's with axis 2 the shells:
 * the four angular neighbours send their sides, the shell inside sends its front, the one
 * outside its back; from shell 0 inward light passes the centre into the antipodal texel's
 * shell 0 (octahedral maps). Also gives the distance between the cells' centroids and the
 * factor on the source's L:
 * - the radial compensation: the lobe's power L A is what moves, so L arrives scaled by
 *   A(src) / A(dst), the ratio of the cells' mean sections. Along the principal direction this
 *   is flux conservation through the shells (in free space L A is the same in every shell, and
 *   L falls as 1 / r^2); sideways it is the ratio of the texels' solid angles;
 * - sideways, texels differ in size (5-fold in solid angle on the octahedral map). Sending each
 *   neighbour side(a) of the power makes the power per texel uniform at equilibrium, and the
 *   fluence ~ 1 / Omega (measured: 27% less ms along the diagonals than along the axes). So the
 *   source sends side(a) min(Omega(src), Omega(dst)) / Omega(src) of its power to each
 *   neighbour and keeps the rest of 4 side(a) (s = 6, the cell itself, once a texel's width
 *   away): transfers then balance in detail for power ~ Omega, i.e. for uniform fluence. */
VS_FUNC int vs_pop_radial_source(VS_DATA_PARAM(vs_uint, pop_params) int i, int j, int k, int s,
                                 PNANOVDB_INOUT(int) send, PNANOVDB_INOUT(float) dist,
                                 PNANOVDB_INOUT(float) scale)
{
    int n0 = vs_pop_n(VS_DATA_ARG(pop_params) 0);
    int n1 = vs_pop_n(VS_DATA_ARG(pop_params) 1);
    int n2 = vs_pop_n(VS_DATA_ARG(pop_params) 2);
    int texel = j * n0 + i;
    int src_texel = texel;
    int src_k = k;
    PNANOVDB_DEREF(send) = VS_POP_SEND_SIDE;
    if (s < 4) {
        src_texel = vs_pop_texel_step(VS_DATA_ARG(pop_params) i, j, s == 0 ? -1 : (s == 1 ? 1 : 0),
                                      s == 2 ? -1 : (s == 3 ? 1 : 0));
    } else if (s == 6) {
        float r = vs_pop_radial_centre(VS_DATA_ARG(pop_params) k);
        PNANOVDB_DEREF(dist) =
            r * vs_sqrt(vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_OMEGA));
        PNANOVDB_DEREF(scale) =
            4.0f * vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_STAY);
        return (k * n1 + j) * n0 + i;
    } else if (s == 4) {
        PNANOVDB_DEREF(send) = VS_POP_SEND_FRONT;
        src_k = k - 1;
        if (k == 0) {
            src_k = 0;
            PNANOVDB_DEREF(send) = VS_POP_SEND_BACK;
            src_texel = pop_params[VS_POP_OFF_WRAP] != 0u
                            ? vs_pop_antipode(VS_DATA_ARG(pop_params) i, j)
                            : -1;
        }
    } else {
        PNANOVDB_DEREF(send) = VS_POP_SEND_BACK;
        src_k = k + 1;
        if (k + 1 >= n2)
            src_texel = -1;
    }
    if (src_texel < 0)
        return -1;
    float r_dst = vs_pop_radial_centre(VS_DATA_ARG(pop_params) k);
    float r_src = vs_pop_radial_centre(VS_DATA_ARG(pop_params) src_k);
    float dx = 0.0f, dy = 0.0f, dz = 0.0f;
    {
        float x0 = vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_DIR);
        float y0 = vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_DIR + 1);
        float z0 = vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_DIR + 2);
        float x1 = vs_pop_texel(VS_DATA_ARG(pop_params) src_texel, VS_POP_TEXEL_DIR);
        float y1 = vs_pop_texel(VS_DATA_ARG(pop_params) src_texel, VS_POP_TEXEL_DIR + 1);
        float z1 = vs_pop_texel(VS_DATA_ARG(pop_params) src_texel, VS_POP_TEXEL_DIR + 2);
        dx = r_src * x1 - r_dst * x0;
        dy = r_src * y1 - r_dst * y0;
        dz = r_src * z1 - r_dst * z0;
    }
    PNANOVDB_DEREF(dist) = vs_sqrt(dx * dx + dy * dy + dz * dz);
    float omega_src = vs_pop_texel(VS_DATA_ARG(pop_params) src_texel, VS_POP_TEXEL_OMEGA);
    float split =
        s < 4 ? vs_min(omega_src, vs_pop_texel(VS_DATA_ARG(pop_params) texel, VS_POP_TEXEL_OMEGA)) /
                    omega_src
              : 1.0f;
    PNANOVDB_DEREF(scale) = pop_params[VS_POP_OFF_COMPENSATE] != 0u
                                ? split *
                                      vs_pop_radial_area(VS_DATA_ARG(pop_params) src_texel, src_k) /
                                      vs_pop_radial_area(VS_DATA_ARG(pop_params) texel, k)
                                : split;
    return (src_k * n1 + src_texel / n0) * n0 + src_texel % n0;
}

/* ---- the gather ---- */

/* One iteration at cell `cell`: the new lobe from the six neighbours' lobes in pop_state_in,
 * and the accumulated sums carried forward, written to pop_state_out[out_base ..
 * out_base + VS_POP_STATE_WORDS). Returns the energy still in transit at the cell: the new
 * lobe's magnitude summed over the channels, times A(cell) on radial grids (its power). */
VS_FUNC float vs_pop_gather(VS_DATA_PARAM(vs_uint, pop_params) VS_DATA_PARAM(float, pop_state_in)
                                VS_DATA_PARAM(float, pop_sigma) int cell,
                            VS_OUT_PARAM(float, pop_state_out) int out_base)
{
    int n0 = vs_pop_n(VS_DATA_ARG(pop_params) 0);
    int n1 = vs_pop_n(VS_DATA_ARG(pop_params) 1);
    float h = vs_pop_param(VS_DATA_ARG(pop_params) VS_POP_OFF_H);
    float g = vs_pop_param(VS_DATA_ARG(pop_params) VS_POP_OFF_G);
    vs_uint mode = pop_params[VS_POP_OFF_DECAY];
    int keep_a = pop_params[VS_POP_OFF_KEEP_A] != 0u ? 1 : 0;
    int radial = pop_params[VS_POP_OFF_KIND] == VS_POP_RADIAL ? 1 : 0;
    int i = cell % n0;
    int j = (cell / n0) % n1;
    int k = cell / (n0 * n1);
    float sigma_dst = pop_sigma[cell];
    /* A cell outside the medium's support box (sigma < 0, radial grids) drops what arrives:
     * light that has left a convex box through vacuum does not come back. */
    int outside = sigma_dst < 0.0f ? 1 : 0;
    float sum_l[3];
    float sum_la[3];
    float albedo[3];
    for (int c = 0; c < 3; ++c) {
        sum_l[c] = 0.0f;
        sum_la[c] = 0.0f;
        albedo[c] = vs_pop_param(VS_DATA_ARG(pop_params) VS_POP_OFF_ALBEDO + c);
    }
    for (int s = 0; s < 6 + radial; ++s) {
        int send = VS_POP_SEND_SIDE;
        float dist = h;
        float scale = 1.0f;
        int src = radial != 0
                      ? vs_pop_radial_source(VS_DATA_ARG(pop_params) i, j, k, s, PNANOVDB_REF(send),
                                             PNANOVDB_REF(dist), PNANOVDB_REF(scale))
                      : vs_pop_rect_source(VS_DATA_ARG(pop_params) i, j, k, s, PNANOVDB_REF(send));
        if (src < 0 || outside != 0 || pop_sigma[src] < 0.0f)
            continue;
        float sigma_mid = 0.5f * (pop_sigma[src] + sigma_dst);
        for (int c = 0; c < 3; ++c) {
            float l = pop_state_in[src * VS_POP_STATE_WORDS + VS_POP_STATE_L + c];
            if (!(l > 0.0f))
                continue;
            float a = pop_state_in[src * VS_POP_STATE_WORDS + VS_POP_STATE_A + c];
            float fraction = send == VS_POP_SEND_SIDE
                                 ? vs_pop_side(a)
                                 : (send == VS_POP_SEND_FRONT ? vs_pop_front(a) : vs_pop_back(a));
            float ts = sigma_mid * albedo[c] * dist;
            float ta = sigma_mid * (1.0f - albedo[c]) * dist;
            VS_PRECISE float dl = l * fraction * vs_exp(-ta) * scale;
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
    return radial != 0 ? total * vs_pop_radial_area(VS_DATA_ARG(pop_params) j * n0 + i, k) : total;
}

#endif
