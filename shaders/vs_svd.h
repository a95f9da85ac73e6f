/* Discrete ordinates with a factored phase (Gong and Ren, docs/methods/svd.md),
 * shared by C and GLSL: the parameter, table and state layouts of one transport sweep and the
 * sweep of one cell. Include after vs_common.h and vs_phase.h. Host side: vdbscatter/svd.c.
 *
 * The grid has n0 x n1 x n2 cubic cells of world side h (cell (i, j, k) is item
 * (k n1 + j) n0 + i). D directions w_d with solid angles dw_d, sorted by octant, are swept
 * octant by octant: a direction's upwind neighbours are the same for its whole octant, so the
 * octant's cells are visited plane by plane in the sweep order (i' + j' + k' = s with i' the
 * index counted from the octant's upwind side), every step one plane, each item one column
 * (i', j'). The step scheme on a cube: the outflow faces carry the cell's value, so
 *   L = (eta h + sum_a mu_a L_in,a) / (sigma_t h + sum_a mu_a),   mu_a = |w_d,a|,
 * and per cell and direction, power in (eta h^3 + inflow) = collisions (sigma_t L h^3) +
 * outflow: conservative by construction, and the tallies of that balance come out per cell.
 *
 * The emission eta (power per volume and steradian) toward w_d is
 *   sum over direct lights l of E_l p_l(w_d)    (the first scattering of a sun's or point's
 *                                                unscattered light, exact: HG(g*) between its
 *                                                direction of travel and w_d, normalised on the
 *                                                directions by the host, folded into E_l)
 * + sum_k v_k(w_d) s_k                          (the factored phase: s_k the host's source
 *                                                moments, lambda_k sigma_s* times the previous
 *                                                sweep's radiance moment plus the sky's first
 *                                                scattering projected on v_k),
 * clamped at 0 where a truncated factorisation goes negative (the clamped power is tallied).
 * Each sweep accumulates the new radiance moments m_k = sum_d v_k(w_d) L_d per cell, and the
 * fluence and net flux that become ms and ms_l1. Memory per cell grows with the terms N, never
 * with D: no radiance is kept per direction except on the two planes in flight. */
#ifndef VS_SVD_H
#define VS_SVD_H

/* Parameter words (`svd_params`: uints, floats as their bits). */
#define VS_SVD_OFF_N 0             /* 3: cells along x, y, z */
#define VS_SVD_OFF_H 3             /* float: world side of a cell */
#define VS_SVD_OFF_TERMS 4         /* N: factored terms (source and state moments per cell) */
#define VS_SVD_OFF_LIGHTS 5        /* direct lights (suns and points) */
#define VS_SVD_OFF_G 6             /* float: g* of the truncated HG the direct lights scatter by */
#define VS_SVD_OFF_CHUNK 7         /* directions of an octant per step */
#define VS_SVD_OFF_CHUNKS 8        /* chunks per octant: steps = 8 chunks (n0 + n1 + n2 - 2) */
#define VS_SVD_OFF_OCTANT 9        /* 9: first direction of octants 0..7, then D */
#define VS_SVD_OFF_ORIGIN 18       /* 3 floats: world position of the grid's first corner */
#define VS_SVD_OFF_EXTINCT 21      /* 3 floats: sigma_t* / sigma_t per channel, 1 - f albedo */
#define VS_SVD_OFF_STATE_OUT 24    /* word offset of the per-cell records in the state */
#define VS_SVD_OFF_STATE_PLANES 25 /* word offset of the two planes in flight */
#define VS_SVD_OFF_TABLE_V 26      /* word offset of v (D x N) in `svd_tables` */
#define VS_SVD_OFF_TABLE_LIGHTS 27 /* word offset of the light records in `svd_tables` */
#define VS_SVD_PARAM_WORDS 28

/* `svd_tables` (floats): D direction records from word 0, then v, then the lights. */
#define VS_SVD_DIR_W 0      /* 3: unit direction of travel */
#define VS_SVD_DIR_WEIGHT 3 /* its solid angle */
#define VS_SVD_DIR_WORDS 4
#define VS_SVD_LIGHT_POINT 0 /* 1: a point light at VEC; 0: a sun travelling along VEC */
#define VS_SVD_LIGHT_VEC 1
#define VS_SVD_LIGHT_WORDS 4

/* Octant o sweeps +x when bit 0 is clear, +y when bit 1 is, +z when bit 2 is; a direction
 * with a zero component belongs to the + side. */
#define VS_SVD_OCTANTS 8

/* The state (floats) the sweeps write, in place: N x 3 new moments per cell from word 0
 * ((cell N + k) 3 + channel), a record per cell at OFF_STATE_OUT, the planes after. */
#define VS_SVD_OUT_FLUENCE 0  /* 3: sum_d L_d dw_d */
#define VS_SVD_OUT_FLUX 3     /* 9: sum_d L_d w_d dw_d, x, y, z components of R, G, B */
#define VS_SVD_OUT_SOURCE 12  /* emitted power eta h^3 dw summed over directions and channels */
#define VS_SVD_OUT_COLLIDE 13 /* collisions sigma_t* L h^3 dw, the same way */
#define VS_SVD_OUT_LEAK 14    /* power out through the grid's boundary faces */
#define VS_SVD_OUT_CLAMPED 15 /* emitted power lost to the clamp at 0 */
#define VS_SVD_OUT_WORDS 16

VS_FUNC float vs_svd_param_float(VS_DATA_PARAM(vs_uint, svd_params) int at)
{
    return vs_word_float(svd_params[at]);
}

/* The unit direction of travel of direct light l at the world point p. */
VS_FUNC pnanovdb_vec3_t vs_svd_light_travel(VS_DATA_PARAM(float, svd_tables) int record,
                                            pnanovdb_vec3_t p)
{
    pnanovdb_vec3_t v =
        vs_vec3(svd_tables[record + VS_SVD_LIGHT_VEC], svd_tables[record + VS_SVD_LIGHT_VEC + 1],
                svd_tables[record + VS_SVD_LIGHT_VEC + 2]);
    if (svd_tables[record + VS_SVD_LIGHT_POINT] == 0.0f)
        return v;
    pnanovdb_vec3_t d = vs_vec3(p.x - v.x, p.y - v.y, p.z - v.z);
    float r = vs_sqrt(vs_vec3_dot(d, d));
    return r > 0.0f ? vs_vec3_scale(d, 1.0f / r) : vs_vec3(0.0f, 0.0f, 1.0f);
}

/* Step `step` of a sweep for column `item`: the one cell of the column on the step's plane,
 * for the step's chunk of its octant's directions. */
VS_FUNC void vs_svd_sweep(VS_DATA_PARAM(vs_uint, svd_params) VS_DATA_PARAM(float, svd_tables)
                              VS_DATA_PARAM(float, svd_sigma) VS_DATA_PARAM(float, svd_direct)
                                  VS_DATA_PARAM(float, svd_source)
                                      VS_OUT_PARAM(float, svd_state) int item,
                          int step)
{
    int n0 = VS_INT(svd_params[VS_SVD_OFF_N]);
    int n1 = VS_INT(svd_params[VS_SVD_OFF_N + 1]);
    int n2 = VS_INT(svd_params[VS_SVD_OFF_N + 2]);
    int planes = n0 + n1 + n2 - 2;
    int plane = step % planes;
    int chunks = VS_INT(svd_params[VS_SVD_OFF_CHUNKS]);
    int chunk = (step / planes) % chunks;
    int octant = step / (planes * chunks);
    int ip = item % n0;
    int jp = item / n0;
    int kp = plane - ip - jp;
    if (jp >= n1 || kp < 0 || kp >= n2)
        return;
    int chunk_dirs = VS_INT(svd_params[VS_SVD_OFF_CHUNK]);
    int first = VS_INT(svd_params[VS_SVD_OFF_OCTANT + octant]) + chunk * chunk_dirs;
    int end = VS_INT(svd_params[VS_SVD_OFF_OCTANT + octant + 1]);
    if (first + chunk_dirs < end)
        end = first + chunk_dirs;
    if (first >= end)
        return;
    int i = (octant & 1) != 0 ? n0 - 1 - ip : ip;
    int j = (octant & 2) != 0 ? n1 - 1 - jp : jp;
    int k = (octant & 4) != 0 ? n2 - 1 - kp : kp;
    int cell = (k * n1 + j) * n0 + i;
    int terms = VS_INT(svd_params[VS_SVD_OFF_TERMS]);
    int lights = VS_INT(svd_params[VS_SVD_OFF_LIGHTS]);
    float h = vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_H);
    float g = vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_G);
    float volume = h * h * h;
    float area = h * h;
    pnanovdb_vec3_t centre = vs_vec3(
        vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_ORIGIN) + (VS_FLOAT(i) + 0.5f) * h,
        vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_ORIGIN + 1) +
            (VS_FLOAT(j) + 0.5f) * h,
        vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_ORIGIN + 2) +
            (VS_FLOAT(k) + 0.5f) * h);
    float sigma = svd_sigma[cell];
    float st0 = sigma * vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_EXTINCT);
    float st1 = sigma * vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_EXTINCT + 1);
    float st2 = sigma * vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_EXTINCT + 2);
    int v_at = VS_INT(svd_params[VS_SVD_OFF_TABLE_V]);
    int light_at = VS_INT(svd_params[VS_SVD_OFF_TABLE_LIGHTS]);
    int record = VS_INT(svd_params[VS_SVD_OFF_STATE_OUT]) + cell * VS_SVD_OUT_WORDS;
    int columns = n0 * n1;
    int plane_at = VS_INT(svd_params[VS_SVD_OFF_STATE_PLANES]);
    int here = plane_at + (plane & 1) * chunk_dirs * columns * 3;
    int back = plane_at + ((plane + 1) & 1) * chunk_dirs * columns * 3;
    int column = jp * n0 + ip;
    /* Per-cell tallies, kept in float: a cell's terms are of one size. */
    float fl0 = 0.0f, fl1 = 0.0f, fl2 = 0.0f;
    float fx0 = 0.0f, fx1 = 0.0f, fx2 = 0.0f, fy0 = 0.0f, fy1 = 0.0f, fy2 = 0.0f;
    float fz0 = 0.0f, fz1 = 0.0f, fz2 = 0.0f;
    float emitted = 0.0f, collided = 0.0f, leaked = 0.0f, clamped = 0.0f;
    for (int d = first; d < end; ++d) {
        int rec = d * VS_SVD_DIR_WORDS;
        pnanovdb_vec3_t w =
            vs_vec3(svd_tables[rec + VS_SVD_DIR_W], svd_tables[rec + VS_SVD_DIR_W + 1],
                    svd_tables[rec + VS_SVD_DIR_W + 2]);
        float dw = svd_tables[rec + VS_SVD_DIR_WEIGHT];
        VS_PRECISE float q0 = 0.0f;
        VS_PRECISE float q1 = 0.0f;
        VS_PRECISE float q2 = 0.0f;
        for (int l = 0; l < lights; ++l) {
            pnanovdb_vec3_t travel = vs_svd_light_travel(
                VS_DATA_ARG(svd_tables) light_at + l * VS_SVD_LIGHT_WORDS, centre);
            float p = vs_hg_dirs(g, travel, w);
            int e = (cell * lights + l) * 3;
            q0 += svd_direct[e] * p;
            q1 += svd_direct[e + 1] * p;
            q2 += svd_direct[e + 2] * p;
        }
        int vrow = v_at + d * terms;
        int src = cell * terms * 3;
        for (int t = 0; t < terms; ++t) {
            float v = svd_tables[vrow + t];
            q0 += v * svd_source[src + 3 * t];
            q1 += v * svd_source[src + 3 * t + 1];
            q2 += v * svd_source[src + 3 * t + 2];
        }
        /* A truncated factorisation can emit negative light: clamp, and count what it cost. */
        clamped -= (vs_min(q0, 0.0f) + vs_min(q1, 0.0f) + vs_min(q2, 0.0f)) * dw * volume;
        q0 = vs_max(q0, 0.0f);
        q1 = vs_max(q1, 0.0f);
        q2 = vs_max(q2, 0.0f);
        float mx = vs_abs(w.x);
        float my = vs_abs(w.y);
        float mz = vs_abs(w.z);
        int slot = (d - first) * columns;
        /* Upwind inflow: the column before along each axis on the previous plane (0 at the
         * grid's inflow faces: vacuum). */
        float ax0 = 0.0f, ax1 = 0.0f, ax2 = 0.0f, ay0 = 0.0f, ay1 = 0.0f, ay2 = 0.0f;
        float az0 = 0.0f, az1 = 0.0f, az2 = 0.0f;
        if (ip > 0) {
            int at = back + (slot + column - 1) * 3;
            ax0 = svd_state[at];
            ax1 = svd_state[at + 1];
            ax2 = svd_state[at + 2];
        }
        if (jp > 0) {
            int at = back + (slot + column - n0) * 3;
            ay0 = svd_state[at];
            ay1 = svd_state[at + 1];
            ay2 = svd_state[at + 2];
        }
        if (kp > 0) {
            int at = back + (slot + column) * 3;
            az0 = svd_state[at];
            az1 = svd_state[at + 1];
            az2 = svd_state[at + 2];
        }
        float open = mx + my + mz;
        float l0 = (q0 * h + mx * ax0 + my * ay0 + mz * az0) / (st0 * h + open);
        float l1 = (q1 * h + mx * ax1 + my * ay1 + mz * az1) / (st1 * h + open);
        float l2 = (q2 * h + mx * ax2 + my * ay2 + mz * az2) / (st2 * h + open);
        int put = here + (slot + column) * 3;
        svd_state[put] = l0;
        svd_state[put + 1] = l1;
        svd_state[put + 2] = l2;
        for (int t = 0; t < terms; ++t) {
            float v = svd_tables[vrow + t];
            int m = (cell * terms + t) * 3;
            svd_state[m] += v * l0;
            svd_state[m + 1] += v * l1;
            svd_state[m + 2] += v * l2;
        }
        fl0 += l0 * dw;
        fl1 += l1 * dw;
        fl2 += l2 * dw;
        fx0 += l0 * w.x * dw;
        fx1 += l1 * w.x * dw;
        fx2 += l2 * w.x * dw;
        fy0 += l0 * w.y * dw;
        fy1 += l1 * w.y * dw;
        fy2 += l2 * w.y * dw;
        fz0 += l0 * w.z * dw;
        fz1 += l1 * w.z * dw;
        fz2 += l2 * w.z * dw;
        emitted += (q0 + q1 + q2) * dw * volume;
        collided += (st0 * l0 + st1 * l1 + st2 * l2) * dw * volume;
        float faces =
            (ip == n0 - 1 ? mx : 0.0f) + (jp == n1 - 1 ? my : 0.0f) + (kp == n2 - 1 ? mz : 0.0f);
        leaked += faces * (l0 + l1 + l2) * dw * area;
    }
    svd_state[record + VS_SVD_OUT_FLUENCE] += fl0;
    svd_state[record + VS_SVD_OUT_FLUENCE + 1] += fl1;
    svd_state[record + VS_SVD_OUT_FLUENCE + 2] += fl2;
    svd_state[record + VS_SVD_OUT_FLUX] += fx0;
    svd_state[record + VS_SVD_OUT_FLUX + 1] += fx1;
    svd_state[record + VS_SVD_OUT_FLUX + 2] += fx2;
    svd_state[record + VS_SVD_OUT_FLUX + 3] += fy0;
    svd_state[record + VS_SVD_OUT_FLUX + 4] += fy1;
    svd_state[record + VS_SVD_OUT_FLUX + 5] += fy2;
    svd_state[record + VS_SVD_OUT_FLUX + 6] += fz0;
    svd_state[record + VS_SVD_OUT_FLUX + 7] += fz1;
    svd_state[record + VS_SVD_OUT_FLUX + 8] += fz2;
    svd_state[record + VS_SVD_OUT_SOURCE] += emitted;
    svd_state[record + VS_SVD_OUT_COLLIDE] += collided;
    svd_state[record + VS_SVD_OUT_LEAK] += leaked;
    svd_state[record + VS_SVD_OUT_CLAMPED] += clamped;
}

#endif
