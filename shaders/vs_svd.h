/* Discrete ordinates with a factored phase (Gong and Ren, docs/methods/svd.md),
 * shared by C and GLSL: the parameter, table and state layouts of one transport sweep and the
 * sweep of one cell. Include after vs_common.h and vs_phase.h. Host side: vdbscatter/solvers/svd.c.
 *
 * The grid has n0 x n1 x n2 box cells of world sides h_x, h_y, h_z (cell (i, j, k) is item
 * (k n1 + j) n0 + i): cubic for most volumes, shorter along a thin layer's thickness. D directions
 * w_d with solid angles dw_d, sorted by octant, are swept octant by octant: a direction's upwind
 * neighbours are the same for its whole octant, so the octant's cells are visited plane by plane in
 * the sweep order (i' + j' + k' = s with i' the index counted from the octant's upwind side), every
 * step one plane, each item one column (i', j'). The cell scheme on a box: along each axis a the
 * cell's mean L = alpha_a L_out,a + (1 - alpha_a) L_in,a. The step scheme (the default) has
 * alpha_a = 1, every outflow face the cell's mean; the weighted diamond (VS_SVD_OFF_SCHEME) has
 * the slab weight of the axis's optical depth (vs_svd_slab_weight: exact for light that only
 * attenuates, 1/2 in thin cells, 1 in thick ones), which removes most of the step's sideways
 * spreading, a numerical diffusion of the order of the cell per free path. With r_a = h / h_a
 * (h the largest side; 1 on a cube) and mu_a = |w_d,a|, the balance
 * sigma_t h L + sum_a r_a mu_a (L_out,a - L_in,a) = eta h gives
 * L = (eta h + sum_a (r_a mu_a / alpha_a) L_in,a) / (sigma_t h + sum_a r_a mu_a / alpha_a), and
 * per cell and direction power in (eta V + inflow) = collisions (sigma_t L V) + outflow
 * (V = h_x h_y h_z, face a's area V / h_a): conservative by construction (a face held at 0 rather
 * than negative stays so: vs_svd_cell_channel), and the tallies of that balance come out per cell.
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
#define VS_SVD_OFF_H 3             /* float: the largest world side of a cell */
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
#define VS_SVD_OFF_SIDE 28         /* 3 floats: world side of a cell along x, y, z */
#define VS_SVD_OFF_SCHEME 31       /* 0: the step scheme; 1: the weighted diamond */
/* The radiance arriving from outside through every boundary face, in every direction (the
 * sky's uniform part, vdbscatter/skyfloor.h; 0: vacuum), per channel. */
#define VS_SVD_OFF_INFLOW 32 /* 3 floats */
#define VS_SVD_PARAM_WORDS 35

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
 * (vs_svd_moment_at), a record per cell at OFF_STATE_OUT, the planes after. */
#define VS_SVD_OUT_FLUENCE 0  /* 3: sum_d L_d dw_d */
#define VS_SVD_OUT_FLUX 3     /* 9: sum_d L_d w_d dw_d, x, y, z components of R, G, B */
#define VS_SVD_OUT_SOURCE 12  /* power in: emitted eta h^3 dw and inflow, summed */
#define VS_SVD_OUT_COLLIDE 13 /* collisions sigma_t* L h^3 dw, the same way */
#define VS_SVD_OUT_LEAK 14    /* power out through the grid's boundary faces */
#define VS_SVD_OUT_CLAMPED 15 /* emitted power lost to the clamp at 0 */
#define VS_SVD_OUT_WORDS 16
/* A column's words on a plane in flight, per direction: its cell's outflow on the far x, y and
 * z faces, 3 channels each (the diamond). The step's three faces all carry the cell's mean, so
 * it keeps only the first. */
#define VS_SVD_FACE_X 0
#define VS_SVD_FACE_Y 3
#define VS_SVD_FACE_Z 6
#define VS_SVD_FACE_WORDS_DIAMOND 9
#define VS_SVD_FACE_WORDS_STEP 3

VS_FUNC int vs_svd_face_words(int diamond)
{
    return diamond != 0 ? VS_SVD_FACE_WORDS_DIAMOND : VS_SVD_FACE_WORDS_STEP;
}

/* The word of face (VS_SVD_FACE_X, _Y or _Z) in a column's words: the step keeps one. */
VS_FUNC int vs_svd_face_word(int face_words, int face)
{
    return face < face_words ? face : VS_SVD_FACE_X;
}

/* The word of term k, channel ch of a cell's moments (the state's and the source's): a cell's
 * terms lie contiguous per channel, so that a direction's sums over them run in SIMD lanes. */
VS_FUNC int vs_svd_moment_at(int cell, int terms, int k, int ch)
{
    return (cell * 3 + ch) * terms + k;
}

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

/* Where step `step` of a sweep works for column `item` (i', j'): the one cell of the column on
 * the step's plane, for the step's chunk of its octant's directions. */
struct vs_svd_at {
    int ip, jp, kp; /* the cell counted from the octant's upwind side */
    int cell;       /* its item in the grid */
    int column;     /* jp n0 + ip: its slot on the planes in flight */
    int here, back; /* word offsets of this step's plane and of the previous step's */
    int first, end; /* the step's directions; first >= end: nothing to do */
    int chunk_dirs; /* directions per chunk (the planes' stride) */
    int face_words; /* a column's words per direction on a plane (vs_svd_face_words) */
};
PNANOVDB_STRUCT_TYPEDEF(vs_svd_at)

VS_FUNC vs_svd_at vs_svd_locate(VS_DATA_PARAM(vs_uint, svd_params) int item, int step)
{
    int n0 = VS_INT(svd_params[VS_SVD_OFF_N]);
    int n1 = VS_INT(svd_params[VS_SVD_OFF_N + 1]);
    int n2 = VS_INT(svd_params[VS_SVD_OFF_N + 2]);
    int planes = n0 + n1 + n2 - 2;
    int plane = step % planes;
    int chunks = VS_INT(svd_params[VS_SVD_OFF_CHUNKS]);
    int chunk = (step / planes) % chunks;
    int octant = step / (planes * chunks);
    vs_svd_at at;
    at.ip = item % n0;
    at.jp = item / n0;
    at.kp = plane - at.ip - at.jp;
    at.chunk_dirs = VS_INT(svd_params[VS_SVD_OFF_CHUNK]);
    at.first = VS_INT(svd_params[VS_SVD_OFF_OCTANT + octant]) + chunk * at.chunk_dirs;
    at.end = VS_INT(svd_params[VS_SVD_OFF_OCTANT + octant + 1]);
    if (at.first + at.chunk_dirs < at.end)
        at.end = at.first + at.chunk_dirs;
    if (at.jp >= n1 || at.kp < 0 || at.kp >= n2)
        at.end = at.first; /* the column has no cell on this plane */
    int i = (octant & 1) != 0 ? n0 - 1 - at.ip : at.ip;
    int j = (octant & 2) != 0 ? n1 - 1 - at.jp : at.jp;
    int k = (octant & 4) != 0 ? n2 - 1 - at.kp : at.kp;
    at.cell = (k * n1 + j) * n0 + i;
    at.column = at.jp * n0 + at.ip;
    int columns = n0 * n1;
    int plane_at = VS_INT(svd_params[VS_SVD_OFF_STATE_PLANES]);
    at.face_words = vs_svd_face_words(VS_INT(svd_params[VS_SVD_OFF_SCHEME]));
    at.here = plane_at + (plane & 1) * at.chunk_dirs * columns * at.face_words;
    at.back = plane_at + ((plane + 1) & 1) * at.chunk_dirs * columns * at.face_words;
    return at;
}

/* What the cell's directions share: the grid, the medium, the tables' layout. */
struct vs_svd_cell {
    int n0, n1, n2;
    int terms, lights;
    int v_at, light_at; /* word offsets in svd_tables */
    int record;         /* word offset of the cell's record in the state */
    int diamond;        /* VS_SVD_OFF_SCHEME */
    float h, g, volume, area;
    pnanovdb_vec3_t side;   /* world sides along x, y, z */
    pnanovdb_vec3_t ratio;  /* h / side: the faces' weights in the step (1 on a cube) */
    pnanovdb_vec3_t faces;  /* face areas along x, y, z over area (1 on a cube) */
    pnanovdb_vec3_t centre; /* world */
    pnanovdb_vec3_t st;     /* sigma_t* per channel */
    pnanovdb_vec3_t inflow; /* VS_SVD_OFF_INFLOW */
};
PNANOVDB_STRUCT_TYPEDEF(vs_svd_cell)

VS_FUNC vs_svd_cell vs_svd_cell_of(VS_DATA_PARAM(vs_uint, svd_params)
                                       VS_DATA_PARAM(float, svd_sigma) vs_svd_at at)
{
    vs_svd_cell c;
    c.n0 = VS_INT(svd_params[VS_SVD_OFF_N]);
    c.n1 = VS_INT(svd_params[VS_SVD_OFF_N + 1]);
    c.n2 = VS_INT(svd_params[VS_SVD_OFF_N + 2]);
    c.terms = VS_INT(svd_params[VS_SVD_OFF_TERMS]);
    c.lights = VS_INT(svd_params[VS_SVD_OFF_LIGHTS]);
    c.v_at = VS_INT(svd_params[VS_SVD_OFF_TABLE_V]);
    c.light_at = VS_INT(svd_params[VS_SVD_OFF_TABLE_LIGHTS]);
    c.record = VS_INT(svd_params[VS_SVD_OFF_STATE_OUT]) + at.cell * VS_SVD_OUT_WORDS;
    c.diamond = VS_INT(svd_params[VS_SVD_OFF_SCHEME]);
    c.h = vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_H);
    c.g = vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_G);
    c.side = vs_vec3(vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_SIDE),
                     vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_SIDE + 1),
                     vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_SIDE + 2));
    c.ratio = vs_vec3(c.h / c.side.x, c.h / c.side.y, c.h / c.side.z);
    c.volume = c.side.x * c.side.y * c.side.z;
    c.area = c.h * c.h;
    c.faces = vs_vec3(c.side.y * c.side.z / c.area, c.side.x * c.side.z / c.area,
                      c.side.x * c.side.y / c.area);
    int i = at.cell % c.n0;
    int j = (at.cell / c.n0) % c.n1;
    int k = at.cell / (c.n0 * c.n1);
    c.centre = vs_vec3(vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_ORIGIN) +
                           (VS_FLOAT(i) + 0.5f) * c.side.x,
                       vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_ORIGIN + 1) +
                           (VS_FLOAT(j) + 0.5f) * c.side.y,
                       vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_ORIGIN + 2) +
                           (VS_FLOAT(k) + 0.5f) * c.side.z);
    float sigma = svd_sigma[at.cell];
    c.st = vs_vec3(sigma * vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_EXTINCT),
                   sigma * vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_EXTINCT + 1),
                   sigma * vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_EXTINCT + 2));
    c.inflow = vs_vec3(vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_INFLOW),
                       vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_INFLOW + 1),
                       vs_svd_param_float(VS_DATA_ARG(svd_params) VS_SVD_OFF_INFLOW + 2));
    return c;
}

/* Partial sums of vs_svd_dot. */
#define VS_SVD_LANES 8

/* sum_t v_t s_t over `terms` v from svd_tables[v_at] and s from svd_source[s_at], as
 * VS_SVD_LANES interleaved partial sums added up in a fixed order: SIMD lanes on the C path,
 * and the same roundings in GLSL, so that the two paths stay bit-identical. */
VS_FUNC_HOT float vs_svd_dot(VS_DATA_PARAM(float, svd_tables)
                                 VS_DATA_PARAM(float, svd_source) int v_at,
                             int s_at, int terms)
{
    VS_PRECISE float lane[VS_SVD_LANES];
    for (int j = 0; j < VS_SVD_LANES; ++j)
        lane[j] = 0.0f;
    int full = terms - terms % VS_SVD_LANES;
    for (int t = 0; t < full; t += VS_SVD_LANES) {
        VS_SIMD
        for (int j = 0; j < VS_SVD_LANES; ++j)
            lane[j] += svd_tables[v_at + t + j] * svd_source[s_at + t + j];
    }
    for (int j = 0; full + j < terms; ++j)
        lane[j] += svd_tables[v_at + full + j] * svd_source[s_at + full + j];
    VS_PRECISE float low = (lane[0] + lane[4]) + (lane[1] + lane[5]);
    VS_PRECISE float high = (lane[2] + lane[6]) + (lane[3] + lane[7]);
    return low + high;
}

/* The emission toward w (direction d) at the cell, per channel, before the clamp: the direct
 * lights' first scattering and the factored phase's source moments. */
VS_FUNC_HOT pnanovdb_vec3_t vs_svd_emission(VS_DATA_PARAM(float, svd_tables)
                                                VS_DATA_PARAM(float, svd_direct)
                                                    VS_DATA_PARAM(float, svd_source) vs_svd_cell c,
                                            int cell, pnanovdb_vec3_t w, int d)
{
    VS_PRECISE float q0 = 0.0f;
    VS_PRECISE float q1 = 0.0f;
    VS_PRECISE float q2 = 0.0f;
    for (int l = 0; l < c.lights; ++l) {
        pnanovdb_vec3_t travel = vs_svd_light_travel(
            VS_DATA_ARG(svd_tables) c.light_at + l * VS_SVD_LIGHT_WORDS, c.centre);
        float p = vs_hg_dirs(c.g, travel, w);
        int e = (cell * c.lights + l) * 3;
        q0 += svd_direct[e] * p;
        q1 += svd_direct[e + 1] * p;
        q2 += svd_direct[e + 2] * p;
    }
    int vrow = c.v_at + d * c.terms;
    int s0 = vs_svd_moment_at(cell, c.terms, 0, 0);
    q0 += vs_svd_dot(VS_DATA_ARG(svd_tables) VS_DATA_ARG(svd_source) vrow, s0, c.terms);
    q1 += vs_svd_dot(VS_DATA_ARG(svd_tables) VS_DATA_ARG(svd_source) vrow, s0 + c.terms, c.terms);
    q2 +=
        vs_svd_dot(VS_DATA_ARG(svd_tables) VS_DATA_ARG(svd_source) vrow, s0 + 2 * c.terms, c.terms);
    return vs_vec3(q0, q1, q2);
}

/* The slab weight alpha of an axis of optical depth tau (the cell's side along the axis over the
 * direction's cosine): the cell's mean radiance is alpha L_out + (1 - alpha) L_in, exact for light
 * that only attenuates across the slab. 1/2 (the diamond) when thin, 1 (the step) when thick:
 * exact attenuation through thick cells without the step's sideways spreading through thin ones. */
/* e^-tau for tau in [0.1, 40] in arithmetic that C and GLSL round alike (the drivers' exp is
 * only within a few ulp, and the slab weight's difference of two terms amplifies that): tau
 * split into n ln 2 + r with |r| <= ln 2 / 2 (ln 2 in two parts), r's Taylor polynomial to
 * degree 7 (relative error below 2e-8), times 2^-n exactly. */
VS_FUNC float vs_svd_exp_neg(float tau)
{
    float n = vs_floor(tau * 1.44269504f + 0.5f);
    VS_PRECISE float r = (n * 0.693145752f - tau) + n * 1.42860677e-6f;
    VS_PRECISE float p =
        1.0f +
        r * (1.0f + r * (0.5f + r * (0.166666667f +
                                     r * (0.0416666667f +
                                          r * (0.00833333333f +
                                               r * (0.00138888889f + r * 0.000198412698f))))));
    return vs_ldexp(p, -VS_INT(n));
}

VS_FUNC float vs_svd_slab_weight(float tau)
{
    if (tau < 0.1f) /* the series: the closed form cancels here */
        return 0.5f + tau / 12.0f - tau * tau * tau / 720.0f;
    if (tau > 40.0f)
        return 1.0f - 1.0f / tau;
    return 1.0f / (1.0f - vs_svd_exp_neg(tau)) - 1.0f / tau;
}

/* One channel of a cell for one direction: the mean radiance and the outflow on each axis's far
 * face (outflow), from the emission q, sigma_t* st and the inflows. open[a] = |w_a| h / side_a
 * weighs face a (0: the direction does not cross it). alpha_a is the slab weight with `diamond`,
 * else 1 (the step: every face the mean, never negative). The balance
 *   st h L + sum_a open_a (out_a - in_a) = q h,   L = alpha_a out_a + (1 - alpha_a) in_a
 * gives L; a face whose extrapolated outflow would be negative is held at 0 and L solved again
 * without it, which keeps the balance exact (the next pass only raises L, so two passes settle
 * every face; the third is a guard). */
VS_FUNC_HOT float vs_svd_cell_channel(int diamond, float q, float st, float h, pnanovdb_vec3_t open,
                                      pnanovdb_vec3_t inflow,
                                      PNANOVDB_INOUT(pnanovdb_vec3_t) outflow)
{
    float o[3];
    float i[3];
    float a[3];
    int held[3];
    o[0] = open.x;
    o[1] = open.y;
    o[2] = open.z;
    i[0] = inflow.x;
    i[1] = inflow.y;
    i[2] = inflow.z;
    for (int ax = 0; ax < 3; ++ax) {
        a[ax] = diamond != 0 && o[ax] > 0.0f ? vs_svd_slab_weight(st * h / o[ax]) : 1.0f;
        held[ax] = 0;
    }
    float l = 0.0f;
    float f[3];
    for (int pass = 0; pass < 3; ++pass) {
        VS_PRECISE float num = q * h;
        VS_PRECISE float den = st * h;
        for (int ax = 0; ax < 3; ++ax) {
            if (held[ax] != 0) {
                num += o[ax] * i[ax];
            } else {
                num += o[ax] / a[ax] * i[ax];
                den += o[ax] / a[ax];
            }
        }
        l = den > 0.0f ? num / den : 0.0f;
        int more = 0;
        for (int ax = 0; ax < 3; ++ax) {
            f[ax] = held[ax] != 0 ? 0.0f : (l - (1.0f - a[ax]) * i[ax]) / a[ax];
            if (f[ax] < 0.0f) {
                f[ax] = 0.0f;
                held[ax] = 1;
                more = 1;
            }
        }
        if (more == 0)
            break;
    }
    PNANOVDB_DEREF(outflow) = vs_vec3(f[0], f[1], f[2]);
    return l;
}

/* A cell's outflow for one direction: each axis's far face per channel, as the planes hold it. */
struct vs_svd_faces {
    pnanovdb_vec3_t x, y, z;
};
PNANOVDB_STRUCT_TYPEDEF(vs_svd_faces)

VS_FUNC pnanovdb_vec3_t vs_svd_load3(VS_OUT_PARAM(float, svd_state) int at)
{
    return vs_vec3(svd_state[at], svd_state[at + 1], svd_state[at + 2]);
}

VS_FUNC void vs_svd_store3(VS_OUT_PARAM(float, svd_state) int at, pnanovdb_vec3_t v)
{
    svd_state[at] = v.x;
    svd_state[at + 1] = v.y;
    svd_state[at + 2] = v.z;
}

/* The cell's radiance toward w from its emission q (clamped) and the upwind inflow: the far face
 * of the column before along each axis on the previous plane, the radiance from outside
 * (VS_SVD_OFF_INFLOW; 0: vacuum) at the grid's inflow faces. Its outflow faces go to `faces`. */
VS_FUNC_HOT pnanovdb_vec3_t vs_svd_upwind(VS_OUT_PARAM(float, svd_state) vs_svd_at at,
                                          vs_svd_cell c, int slot, pnanovdb_vec3_t q,
                                          pnanovdb_vec3_t w, PNANOVDB_INOUT(vs_svd_faces) faces)
{
    pnanovdb_vec3_t open =
        vs_vec3(vs_abs(w.x) * c.ratio.x, vs_abs(w.y) * c.ratio.y, vs_abs(w.z) * c.ratio.z);
    pnanovdb_vec3_t ax = c.inflow;
    pnanovdb_vec3_t ay = ax;
    pnanovdb_vec3_t az = ax;
    int fw = at.face_words;
    if (at.ip > 0)
        ax = vs_svd_load3(VS_DATA_ARG(svd_state) at.back + (slot + at.column - 1) * fw +
                          vs_svd_face_word(fw, VS_SVD_FACE_X));
    if (at.jp > 0)
        ay = vs_svd_load3(VS_DATA_ARG(svd_state) at.back + (slot + at.column - c.n0) * fw +
                          vs_svd_face_word(fw, VS_SVD_FACE_Y));
    if (at.kp > 0)
        az = vs_svd_load3(VS_DATA_ARG(svd_state) at.back + (slot + at.column) * fw +
                          vs_svd_face_word(fw, VS_SVD_FACE_Z));
    pnanovdb_vec3_t f0 = ax;
    pnanovdb_vec3_t f1 = ax;
    pnanovdb_vec3_t f2 = ax;
    float l0 = vs_svd_cell_channel(c.diamond, q.x, c.st.x, c.h, open, vs_vec3(ax.x, ay.x, az.x),
                                   PNANOVDB_REF(f0));
    float l1 = vs_svd_cell_channel(c.diamond, q.y, c.st.y, c.h, open, vs_vec3(ax.y, ay.y, az.y),
                                   PNANOVDB_REF(f1));
    float l2 = vs_svd_cell_channel(c.diamond, q.z, c.st.z, c.h, open, vs_vec3(ax.z, ay.z, az.z),
                                   PNANOVDB_REF(f2));
    PNANOVDB_DEREF(faces).x = vs_vec3(f0.x, f1.x, f2.x);
    PNANOVDB_DEREF(faces).y = vs_vec3(f0.y, f1.y, f2.y);
    PNANOVDB_DEREF(faces).z = vs_vec3(f0.z, f1.z, f2.z);
    return vs_vec3(l0, l1, l2);
}

/* A cell's tallies over a step's directions, kept in float: a cell's terms are of one size. */
struct vs_svd_tally {
    pnanovdb_vec3_t fluence;
    pnanovdb_vec3_t fx, fy, fz; /* the flux's x, y and z components per channel */
    float emitted, collided, leaked, clamped;
};
PNANOVDB_STRUCT_TYPEDEF(vs_svd_tally)

/* Direction d of the step for the cell: its emission (a truncated factorisation can emit
 * negative light: clamped, and what that cost counted), its radiance onto this step's plane,
 * its share of the new moments and of the tallies. */
VS_FUNC_HOT void vs_svd_direction(VS_DATA_PARAM(float, svd_tables) VS_DATA_PARAM(float, svd_direct)
                                      VS_DATA_PARAM(float, svd_source)
                                          VS_OUT_PARAM(float, svd_state) vs_svd_at at,
                                  vs_svd_cell c, int d, PNANOVDB_INOUT(vs_svd_tally) t)
{
    int rec = d * VS_SVD_DIR_WORDS;
    pnanovdb_vec3_t w = vs_vec3(svd_tables[rec + VS_SVD_DIR_W], svd_tables[rec + VS_SVD_DIR_W + 1],
                                svd_tables[rec + VS_SVD_DIR_W + 2]);
    float dw = svd_tables[rec + VS_SVD_DIR_WEIGHT];
    pnanovdb_vec3_t q = vs_svd_emission(
        VS_DATA_ARG(svd_tables) VS_DATA_ARG(svd_direct) VS_DATA_ARG(svd_source) c, at.cell, w, d);
    PNANOVDB_DEREF(t).clamped -=
        (vs_min(q.x, 0.0f) + vs_min(q.y, 0.0f) + vs_min(q.z, 0.0f)) * dw * c.volume;
    q = vs_vec3(vs_max(q.x, 0.0f), vs_max(q.y, 0.0f), vs_max(q.z, 0.0f));
    int slot = (d - at.first) * c.n0 * c.n1; /* the direction's part of the planes */
    vs_svd_faces leaving;
    pnanovdb_vec3_t l =
        vs_svd_upwind(VS_DATA_ARG(svd_state) at, c, slot, q, w, PNANOVDB_REF(leaving));
    int put = at.here + (slot + at.column) * at.face_words;
    vs_svd_store3(VS_DATA_ARG(svd_state) put + VS_SVD_FACE_X, leaving.x);
    if (at.face_words > VS_SVD_FACE_Y) {
        vs_svd_store3(VS_DATA_ARG(svd_state) put + VS_SVD_FACE_Y, leaving.y);
        vs_svd_store3(VS_DATA_ARG(svd_state) put + VS_SVD_FACE_Z, leaving.z);
    }
    int vrow = c.v_at + d * c.terms;
    int m0 = vs_svd_moment_at(at.cell, c.terms, 0, 0);
    int m1 = m0 + c.terms;
    int m2 = m1 + c.terms;
    VS_SIMD
    for (int k = 0; k < c.terms; ++k) {
        float v = svd_tables[vrow + k];
        svd_state[m0 + k] += v * l.x;
        svd_state[m1 + k] += v * l.y;
        svd_state[m2 + k] += v * l.z;
    }
    PNANOVDB_DEREF(t).fluence =
        vs_vec3(PNANOVDB_DEREF(t).fluence.x + l.x * dw, PNANOVDB_DEREF(t).fluence.y + l.y * dw,
                PNANOVDB_DEREF(t).fluence.z + l.z * dw);
    PNANOVDB_DEREF(t).fx =
        vs_vec3(PNANOVDB_DEREF(t).fx.x + l.x * w.x * dw, PNANOVDB_DEREF(t).fx.y + l.y * w.x * dw,
                PNANOVDB_DEREF(t).fx.z + l.z * w.x * dw);
    PNANOVDB_DEREF(t).fy =
        vs_vec3(PNANOVDB_DEREF(t).fy.x + l.x * w.y * dw, PNANOVDB_DEREF(t).fy.y + l.y * w.y * dw,
                PNANOVDB_DEREF(t).fy.z + l.z * w.y * dw);
    PNANOVDB_DEREF(t).fz =
        vs_vec3(PNANOVDB_DEREF(t).fz.x + l.x * w.z * dw, PNANOVDB_DEREF(t).fz.y + l.y * w.z * dw,
                PNANOVDB_DEREF(t).fz.z + l.z * w.z * dw);
    /* Power in: the emission, and at the grid's inflow faces the radiance from outside. */
    float from_outside = (at.ip == 0 ? vs_abs(w.x) * c.faces.x : 0.0f) +
                         (at.jp == 0 ? vs_abs(w.y) * c.faces.y : 0.0f) +
                         (at.kp == 0 ? vs_abs(w.z) * c.faces.z : 0.0f);
    PNANOVDB_DEREF(t).emitted +=
        (q.x + q.y + q.z) * dw * c.volume +
        from_outside * (c.inflow.x + c.inflow.y + c.inflow.z) * dw * c.area;
    PNANOVDB_DEREF(t).collided += (c.st.x * l.x + c.st.y * l.y + c.st.z * l.z) * dw * c.volume;
    float leak =
        (at.ip == c.n0 - 1 ? vs_abs(w.x) * c.faces.x * (leaving.x.x + leaving.x.y + leaving.x.z)
                           : 0.0f) +
        (at.jp == c.n1 - 1 ? vs_abs(w.y) * c.faces.y * (leaving.y.x + leaving.y.y + leaving.y.z)
                           : 0.0f) +
        (at.kp == c.n2 - 1 ? vs_abs(w.z) * c.faces.z * (leaving.z.x + leaving.z.y + leaving.z.z)
                           : 0.0f);
    PNANOVDB_DEREF(t).leaked += leak * dw * c.area;
}

/* Adds the step's tallies to the cell's record. */
VS_FUNC void vs_svd_tally_store(VS_OUT_PARAM(float, svd_state) int record, vs_svd_tally t)
{
    svd_state[record + VS_SVD_OUT_FLUENCE] += t.fluence.x;
    svd_state[record + VS_SVD_OUT_FLUENCE + 1] += t.fluence.y;
    svd_state[record + VS_SVD_OUT_FLUENCE + 2] += t.fluence.z;
    svd_state[record + VS_SVD_OUT_FLUX] += t.fx.x;
    svd_state[record + VS_SVD_OUT_FLUX + 1] += t.fx.y;
    svd_state[record + VS_SVD_OUT_FLUX + 2] += t.fx.z;
    svd_state[record + VS_SVD_OUT_FLUX + 3] += t.fy.x;
    svd_state[record + VS_SVD_OUT_FLUX + 4] += t.fy.y;
    svd_state[record + VS_SVD_OUT_FLUX + 5] += t.fy.z;
    svd_state[record + VS_SVD_OUT_FLUX + 6] += t.fz.x;
    svd_state[record + VS_SVD_OUT_FLUX + 7] += t.fz.y;
    svd_state[record + VS_SVD_OUT_FLUX + 8] += t.fz.z;
    svd_state[record + VS_SVD_OUT_SOURCE] += t.emitted;
    svd_state[record + VS_SVD_OUT_COLLIDE] += t.collided;
    svd_state[record + VS_SVD_OUT_LEAK] += t.leaked;
    svd_state[record + VS_SVD_OUT_CLAMPED] += t.clamped;
}

/* Step `step` of a sweep for column `item`: the one cell of the column on the step's plane,
 * for the step's chunk of its octant's directions. */
VS_FUNC_HOT void vs_svd_sweep(VS_DATA_PARAM(vs_uint, svd_params) VS_DATA_PARAM(float, svd_tables)
                                  VS_DATA_PARAM(float, svd_sigma) VS_DATA_PARAM(float, svd_direct)
                                      VS_DATA_PARAM(float, svd_source)
                                          VS_OUT_PARAM(float, svd_state) int item,
                              int step)
{
    vs_svd_at at = vs_svd_locate(VS_DATA_ARG(svd_params) item, step);
    if (at.first >= at.end)
        return;
    vs_svd_cell c = vs_svd_cell_of(VS_DATA_ARG(svd_params) VS_DATA_ARG(svd_sigma) at);
    vs_svd_tally t;
    t.fluence = vs_vec3(0.0f, 0.0f, 0.0f);
    t.fx = t.fluence;
    t.fy = t.fluence;
    t.fz = t.fluence;
    t.emitted = 0.0f;
    t.collided = 0.0f;
    t.leaked = 0.0f;
    t.clamped = 0.0f;
    for (int d = at.first; d < at.end; ++d)
        vs_svd_direction(VS_DATA_ARG(svd_tables) VS_DATA_ARG(svd_direct) VS_DATA_ARG(svd_source)
                             VS_DATA_ARG(svd_state) at,
                         c, d, PNANOVDB_REF(t));
    vs_svd_tally_store(VS_DATA_ARG(svd_state) c.record, t);
}

#endif
