/* Light grids (docs/design.md "Light grids"), shared by C and GLSL: the packed layout of a set
 * of grids, the sweep of one column and the optical-depth lookup. Include after
 * vs_common.h and vs_medium.h (and vs_march.h for the sweep). Written by
 * vdbscatter/lights/lightgrid.c.
 *
 * A set is one buffer of 32-bit words (`lgrid_data`: a pointer parameter in C, an SSBO in
 * GLSL): a count, then one header per grid (named offsets below; floats stored as their
 * bits), then each grid's column table, shell radii and depth samples at the word offsets
 * its header gives. A grid has n0 x n1 columns of n2 samples; a column's record is
 * (word offset of its stored samples, first stored sample, stored count). A sweep writes
 * VS_LGRID_SKIPPED as the first sample of a column it skipped. Only the part of
 * a column that can differ is stored: before `first` the depth is 0 (no density met yet),
 * from first + count on it is the last stored value (no density met any more); an empty
 * column stores nothing (count 0: depth 0 all along).
 *
 * Directional grids (a sun or one sky ordinate): sample (i, j, k) sits at
 * origin + i step_u + j step_v + k h travel (index space); column (i, j) is marched from
 * its sample 0 along travel, the index image of the unit world direction of travel, and
 * its sample k is the optical depth at distance k h (world). Radial grids (point lights,
 * POP Sec. 6): column (i, j) is the ray from the light through octahedral texel (i, j),
 * its sample k the depth at the shell radius r_k (world).
 *
 * Lookup: depth, never transmittance, is interpolated. Directional grids: Catmull-Rom
 * across the 4 x 4 nearest columns, kept within the range of the 2 x 2 nearest so that
 * sharp edges of the medium do not ring (Catmull-Rom halves to quarters trilinear's error
 * on clouds), or bilinear across the 2 x 2 nearest (a quarter of the memory traffic, for the
 * render), and linear along the columns. Radial grids: bilinear across texels, linear in r
 * between shells. */
#ifndef VS_LIGHTGRID_H
#define VS_LIGHTGRID_H

#define VS_LGRID_DIRECTIONAL 0u
#define VS_LGRID_RADIAL 1u
/* A lit VDB's stored optical depth (docs/lit-vdb.md): a NanoVDB float grid inside the
 * render's grid buffer (vs_render.h), sampled trilinearly at TO_GRID p + ORIGIN (its own index
 * space: a sun's or sky ordinate's grid lies in the light's frame, a point light's on the
 * density's voxels); only the render reads this kind, since only it holds that buffer. */
#define VS_LGRID_VOXEL 2u
/* The same for a point light: the grid's index space is its radial grid's (texel, texel,
 * shell), the header's N, ORIGIN and RADII as VS_LGRID_RADIAL's. */
#define VS_LGRID_VOXEL_RADIAL 3u

/* The set: grid count, how directional grids interpolate across columns, then the headers
 * from word VS_LGRIDS_OFF_HEADERS on. */
#define VS_LGRIDS_OFF_COUNT 0
#define VS_LGRIDS_OFF_ACROSS 1 /* VS_LGRID_ACROSS_* */
#define VS_LGRID_ACROSS_CATMULL_ROM 0u
#define VS_LGRID_ACROSS_BILINEAR 1u
#define VS_LGRIDS_OFF_HEADERS 4
/* One grid's header, relative to its start. */
#define VS_LGRID_OFF_KIND 0    /* uint: VS_LGRID_DIRECTIONAL or VS_LGRID_RADIAL */
#define VS_LGRID_OFF_N 1       /* 3 uints: columns n0 x n1, samples per column n2 */
#define VS_LGRID_OFF_COLUMNS 4 /* uint: word offset of the column records */
#define VS_LGRID_OFF_RADII 5   /* uint: radial: word offset of the n2 shell radii */
#define VS_LGRID_OFF_SPACING 6 /* float: directional: h, world distance between samples */
/* uint: word offset of one bit per column (j n0 + i), set where the column may meet density;
 * 0: every column may. The sweep skips the others (empty space costs no march). */
#define VS_LGRID_OFF_LIVE 7
#define VS_LGRID_OFF_ORIGIN 8  /* 3 floats, index space: directional sample 0; radial: light */
#define VS_LGRID_OFF_STEP_U 11 /* 3 floats: directional: index step between columns along u */
#define VS_LGRID_OFF_STEP_V 14 /* 3 floats: ... along v */
#define VS_LGRID_OFF_TRAVEL 17 /* 3 floats: directional: index image of the unit travel */
/* 9 floats, directional: rows mapping an index offset from ORIGIN to grid coordinates in
 * samples (u, v, w). */
#define VS_LGRID_OFF_TO_GRID 20
/* uint, VS_LGRID_VOXEL: the float grid's byte offset in the render's grid buffer / 32. */
#define VS_LGRID_OFF_VOXEL_GRID 29
#define VS_LGRID_WORDS 32
/* Column record: words per column and their meaning. */
#define VS_LGRID_COLUMN_OFFSET 0
#define VS_LGRID_COLUMN_FIRST 1
#define VS_LGRID_COLUMN_COUNT 2
#define VS_LGRID_COLUMN_WORDS 3
#define VS_LGRID_SKIPPED (-1.0f)

VS_FUNC vs_uint vs_lgrid_header(int grid)
{
    return VS_UINT(VS_LGRIDS_OFF_HEADERS + grid * VS_LGRID_WORDS);
}

VS_FUNC vs_uint vs_lgrid_word(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int offset)
{
    return lgrid_data[vs_lgrid_header(grid) + VS_UINT(offset)];
}

VS_FUNC float vs_lgrid_float(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int offset)
{
    return vs_word_float(lgrid_data[vs_lgrid_header(grid) + VS_UINT(offset)]);
}

VS_FUNC pnanovdb_vec3_t vs_lgrid_vec3(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int offset)
{
    return vs_vec3(vs_lgrid_float(VS_DATA_ARG(lgrid_data) grid, offset),
                   vs_lgrid_float(VS_DATA_ARG(lgrid_data) grid, offset + 1),
                   vs_lgrid_float(VS_DATA_ARG(lgrid_data) grid, offset + 2));
}

VS_FUNC int vs_lgrid_n(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int axis)
{
    return VS_INT(vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_N + axis));
}

/* Distance (world) of sample k from the start of its column. */
VS_FUNC float vs_lgrid_sample_t(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int k)
{
    if (vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_KIND) == VS_LGRID_RADIAL)
        return vs_word_float(
            lgrid_data[vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_RADII) +
                       VS_UINT(k)]);
    return vs_lgrid_float(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_SPACING) * VS_FLOAT(k);
}

/* Octahedral map of the unit sphere onto [-1, 1]^2: the upper half inside the diamond, the
 * lower half folded over its edges. */
VS_FUNC pnanovdb_vec3_t vs_octahedral_decode(float x, float y)
{
    float z = 1.0f - vs_abs(x) - vs_abs(y);
    if (z < 0.0f) {
        float fx = (1.0f - vs_abs(y)) * (x >= 0.0f ? 1.0f : -1.0f);
        float fy = (1.0f - vs_abs(x)) * (y >= 0.0f ? 1.0f : -1.0f);
        x = fx;
        y = fy;
    }
    float n = vs_sqrt(x * x + y * y + z * z);
    return vs_vec3(x / n, y / n, z / n);
}

/* (x, y) in [-1, 1]^2 of a non-zero vector. */
VS_FUNC pnanovdb_vec3_t vs_octahedral_encode(pnanovdb_vec3_t d)
{
    float n = vs_abs(d.x) + vs_abs(d.y) + vs_abs(d.z);
    float x = d.x / n, y = d.y / n;
    if (d.z < 0.0f) {
        float fx = (1.0f - vs_abs(y)) * (x >= 0.0f ? 1.0f : -1.0f);
        float fy = (1.0f - vs_abs(x)) * (y >= 0.0f ? 1.0f : -1.0f);
        x = fx;
        y = fy;
    }
    return vs_vec3(x, y, 0.0f);
}

/* Index-space start and direction (image of a unit world step) of column (i, j). */
VS_FUNC void vs_lgrid_column_ray(VS_DATA_PARAM(vs_vec4, medium_data)
                                     VS_DATA_PARAM(vs_uint, lgrid_data) int grid,
                                 int i, int j, PNANOVDB_INOUT(pnanovdb_vec3_t) start,
                                 PNANOVDB_INOUT(pnanovdb_vec3_t) dir)
{
    pnanovdb_vec3_t origin = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_ORIGIN);
    if (vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_KIND) == VS_LGRID_RADIAL) {
        float n = VS_FLOAT(vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 0));
        pnanovdb_vec3_t w = vs_octahedral_decode(2.0f * (VS_FLOAT(i) + 0.5f) / n - 1.0f,
                                                 2.0f * (VS_FLOAT(j) + 0.5f) / n - 1.0f);
        PNANOVDB_DEREF(start) = origin;
        PNANOVDB_DEREF(dir) = vs_medium_to_index(VS_DATA_ARG(medium_data) w);
        return;
    }
    pnanovdb_vec3_t su = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_STEP_U);
    pnanovdb_vec3_t sv = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_STEP_V);
    PNANOVDB_DEREF(start) = vs_vec3_madd(vs_vec3_madd(origin, su, VS_FLOAT(i)), sv, VS_FLOAT(j));
    PNANOVDB_DEREF(dir) = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_TRAVEL);
}

/* The sweep needs vs_march.h; in GLSL only the sweep shader (VS_LGRID_SWEEP) has sweep_out. */
#if defined(VS_MARCH_H) && (!defined(PNANOVDB_GLSL) || defined(VS_LGRID_SWEEP))
/* The sweep of one column: the optical depth at each of its n2 samples, by one exact march
 * along the column that stops at every sample, written to out[base + k]. */
VS_FUNC void vs_lgrid_sweep_column(VS_DATA_PARAM(vs_vec4, medium_data)
                                       VS_DATA_PARAM(vs_uint, lgrid_data)
                                           VS_OUT_PARAM(float, sweep_out) pnanovdb_buf_t buf,
                                   PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc, int grid, int i,
                                   int j, vs_uint base)
{
    int n2 = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 2);
    vs_uint live = vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_LIVE);
    if (live != 0u) {
        vs_uint column = VS_UINT(j * vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 0) + i);
        if (((lgrid_data[live + column / 32u] >> (column % 32u)) & 1u) == 0u) {
            sweep_out[base] = VS_LGRID_SKIPPED;
            return;
        }
    }
    pnanovdb_vec3_t start = vs_vec3(0.0f, 0.0f, 0.0f);
    pnanovdb_vec3_t dir = vs_vec3(0.0f, 0.0f, 0.0f);
    vs_lgrid_column_ray(VS_DATA_ARG(medium_data) VS_DATA_ARG(lgrid_data) grid, i, j,
                        PNANOVDB_REF(start), PNANOVDB_REF(dir));
    vs_march_state m =
        vs_march_begin(start, dir, vs_lgrid_sample_t(VS_DATA_ARG(lgrid_data) grid, n2 - 1),
                       vs_medium_box_lo(VS_DATA_ONLY_ARG(medium_data)),
                       vs_medium_box_hi(VS_DATA_ONLY_ARG(medium_data)),
                       vs_medium_density_scale(VS_DATA_ONLY_ARG(medium_data)));
    sweep_out[base] = 0.0f;
    for (int k = 1; k < n2; ++k) {
        vs_march_advance(buf, acc, PNANOVDB_REF(m),
                         vs_lgrid_sample_t(VS_DATA_ARG(lgrid_data) grid, k));
        /* Past VS_TAU_LIMIT the march stops: the transmittance is 0 in float from there. */
        sweep_out[base + VS_UINT(k)] = vs_accum_value(m.tau);
    }
}
#endif

/* Depth at sample k + f (0 <= k < n2) of the column whose record starts at word `record`,
 * linear along the column. */
VS_FUNC float vs_lgrid_record_depth(VS_DATA_PARAM(vs_uint, lgrid_data) vs_uint record, int n2,
                                    int k, float f)
{
    int count = VS_INT(lgrid_data[record + VS_UINT(VS_LGRID_COLUMN_COUNT)]);
    if (count == 0)
        return 0.0f;
    vs_uint at = lgrid_data[record + VS_UINT(VS_LGRID_COLUMN_OFFSET)];
    int first = VS_INT(lgrid_data[record + VS_UINT(VS_LGRID_COLUMN_FIRST)]);
    int a = k - first;
    int b = (k + 1 < n2 ? k + 1 : k) - first;
    float da = a < 0 ? 0.0f : vs_word_float(lgrid_data[at + VS_UINT(a < count ? a : count - 1)]);
    float db = b < 0 ? 0.0f : vs_word_float(lgrid_data[at + VS_UINT(b < count ? b : count - 1)]);
    VS_PRECISE float d = da + f * (db - da);
    return d;
}

/* Word of column (i, j)'s record. */
VS_FUNC vs_uint vs_lgrid_record(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int i, int j)
{
    return vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_COLUMNS) +
           VS_UINT(VS_LGRID_COLUMN_WORDS * (j * vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 0) + i));
}

/* Depth of column (i, j) at sample k + f. */
VS_FUNC float vs_lgrid_column_depth(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int i, int j,
                                    int k, float f)
{
    return vs_lgrid_record_depth(VS_DATA_ARG(lgrid_data)
                                     vs_lgrid_record(VS_DATA_ARG(lgrid_data) grid, i, j),
                                 vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 2), k, f);
}

/* Index of x clamped to [0, n - 1]; the fraction goes to frac. */
VS_FUNC int vs_lgrid_split(float x, int n, PNANOVDB_INOUT(float) frac)
{
    PNANOVDB_DEREF(frac) = 0.0f;
    if (!(x > 0.0f))
        return 0;
    if (x >= VS_FLOAT(n - 1))
        return n - 1;
    int i = VS_INT(x);
    PNANOVDB_DEREF(frac) = x - VS_FLOAT(i);
    return i;
}

VS_FUNC int vs_lgrid_clamp(int i, int n)
{
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

/* Catmull-Rom weight of the sample at offset a (-1, 0, 1, 2) for a fraction t. */
VS_FUNC float vs_catmull_rom(float t, int a)
{
    float t2 = t * t, t3 = t2 * t;
    if (a == -1)
        return 0.5f * (-t3 + 2.0f * t2 - t);
    if (a == 0)
        return 0.5f * (3.0f * t3 - 5.0f * t2 + 2.0f);
    if (a == 1)
        return 0.5f * (-3.0f * t3 + 4.0f * t2 + t);
    return 0.5f * (t3 - t2);
}

/* Grid coordinate (in samples) of index offset d along row `row` of the map. */
VS_FUNC float vs_lgrid_coordinate(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, int row,
                                  pnanovdb_vec3_t d)
{
    return vs_vec3_dot(vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_TO_GRID + 3 * row),
                       d);
}

VS_FUNC float vs_lgrid_dir_depth(VS_DATA_PARAM(vs_uint, lgrid_data) int grid, pnanovdb_vec3_t p)
{
    pnanovdb_vec3_t o = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_ORIGIN);
    pnanovdb_vec3_t d = vs_vec3(p.x - o.x, p.y - o.y, p.z - o.z);
    int n0 = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 0);
    int n1 = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 1);
    int n2 = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 2);
    vs_uint records = vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_COLUMNS);
    float fu = 0.0f, fv = 0.0f, fw = 0.0f;
    int i = vs_lgrid_split(vs_lgrid_coordinate(VS_DATA_ARG(lgrid_data) grid, 0, d), n0,
                           PNANOVDB_REF(fu));
    int j = vs_lgrid_split(vs_lgrid_coordinate(VS_DATA_ARG(lgrid_data) grid, 1, d), n1,
                           PNANOVDB_REF(fv));
    int k = vs_lgrid_split(vs_lgrid_coordinate(VS_DATA_ARG(lgrid_data) grid, 2, d), n2,
                           PNANOVDB_REF(fw));
    if (lgrid_data[VS_LGRIDS_OFF_ACROSS] == VS_LGRID_ACROSS_BILINEAR) {
        vs_uint row0 = records + VS_UINT(VS_LGRID_COLUMN_WORDS * n0 * j);
        vs_uint row1 = records + VS_UINT(VS_LGRID_COLUMN_WORDS * n0 * vs_lgrid_clamp(j + 1, n1));
        vs_uint di = VS_UINT(VS_LGRID_COLUMN_WORDS * (vs_lgrid_clamp(i + 1, n0) - i));
        vs_uint at = VS_UINT(VS_LGRID_COLUMN_WORDS * i);
        float d00 = vs_lgrid_record_depth(VS_DATA_ARG(lgrid_data) row0 + at, n2, k, fw);
        float d10 = vs_lgrid_record_depth(VS_DATA_ARG(lgrid_data) row0 + at + di, n2, k, fw);
        float d01 = vs_lgrid_record_depth(VS_DATA_ARG(lgrid_data) row1 + at, n2, k, fw);
        float d11 = vs_lgrid_record_depth(VS_DATA_ARG(lgrid_data) row1 + at + di, n2, k, fw);
        VS_PRECISE float d0 = d00 + fu * (d10 - d00);
        VS_PRECISE float d1 = d01 + fu * (d11 - d01);
        VS_PRECISE float d = d0 + fv * (d1 - d0);
        return d;
    }
    float sum = 0.0f, lo = VS_T_INFINITE, hi = -VS_T_INFINITE;
    for (int b = -1; b <= 2; ++b) {
        float wv = vs_catmull_rom(fv, b);
        vs_uint row = records + VS_UINT(VS_LGRID_COLUMN_WORDS * n0 * vs_lgrid_clamp(j + b, n1));
        for (int a = -1; a <= 2; ++a) {
            float x = vs_lgrid_record_depth(
                VS_DATA_ARG(lgrid_data) row +
                    VS_UINT(VS_LGRID_COLUMN_WORDS * vs_lgrid_clamp(i + a, n0)),
                n2, k, fw);
            VS_PRECISE float s = sum + vs_catmull_rom(fu, a) * wv * x;
            sum = s;
            /* Plain comparisons: fminf / fmaxf are calls in C (NaN rules). */
            if (a >= 0 && a <= 1 && b >= 0 && b <= 1) {
                lo = x < lo ? x : lo;
                hi = x > hi ? x : hi;
            }
        }
    }
    /* No overshoot beyond the four nearest columns (sharp edges of the medium). */
    return sum < lo ? lo : (sum > hi ? hi : sum);
}

/* Radial grid `grid`'s coordinates of index-space point p: (texel u, texel v, shell), each a
 * sample index plus the fraction to the next, clamped to the grid as the lookup clamps; w is
 * -1 at the light itself (no direction). */
VS_FUNC pnanovdb_vec3_t vs_lgrid_radial_coords(VS_DATA_PARAM(vs_vec4, medium_data)
                                                   VS_DATA_PARAM(vs_uint, lgrid_data) int grid,
                                               pnanovdb_vec3_t p)
{
    pnanovdb_vec3_t light = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_ORIGIN);
    pnanovdb_vec3_t v = vs_medium_to_world(
        VS_DATA_ARG(medium_data) vs_vec3(p.x - light.x, p.y - light.y, p.z - light.z));
    float r = vs_sqrt(vs_vec3_dot(v, v));
    if (!(r > 0.0f))
        return vs_vec3(0.0f, 0.0f, -1.0f);
    int n = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 0);
    int n2 = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 2);
    pnanovdb_vec3_t e = vs_octahedral_encode(v);
    float fu = 0.0f, fv = 0.0f, fr = 0.0f;
    int i = vs_lgrid_split(0.5f * (e.x + 1.0f) * VS_FLOAT(n) - 0.5f, n, PNANOVDB_REF(fu));
    int j = vs_lgrid_split(0.5f * (e.y + 1.0f) * VS_FLOAT(n) - 0.5f, n, PNANOVDB_REF(fv));
    /* The shell below r (binary search), then linear in r to the next. */
    vs_uint radii = vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_RADII);
    int k = 0, top = n2 - 1;
    if (r >= vs_word_float(lgrid_data[radii + VS_UINT(top)])) {
        k = top;
    } else {
        while (top - k > 1) {
            int mid = (k + top) / 2;
            if (vs_word_float(lgrid_data[radii + VS_UINT(mid)]) <= r)
                k = mid;
            else
                top = mid;
        }
        float r0 = vs_word_float(lgrid_data[radii + VS_UINT(k)]);
        fr = (r - r0) / (vs_word_float(lgrid_data[radii + VS_UINT(k + 1)]) - r0);
    }
    return vs_vec3(VS_FLOAT(i) + fu, VS_FLOAT(j) + fv, VS_FLOAT(k) + fr);
}

/* Bilinear across texels, linear between shells. */
VS_FUNC float vs_lgrid_radial_depth(VS_DATA_PARAM(vs_vec4, medium_data)
                                        VS_DATA_PARAM(vs_uint, lgrid_data) int grid,
                                    pnanovdb_vec3_t p)
{
    pnanovdb_vec3_t c =
        vs_lgrid_radial_coords(VS_DATA_ARG(medium_data) VS_DATA_ARG(lgrid_data) grid, p);
    if (c.z < 0.0f)
        return 0.0f;
    int n = vs_lgrid_n(VS_DATA_ARG(lgrid_data) grid, 0);
    int i = VS_INT(c.x), j = VS_INT(c.y), k = VS_INT(c.z);
    float fu = c.x - VS_FLOAT(i), fv = c.y - VS_FLOAT(j), fr = c.z - VS_FLOAT(k);
    int i1 = i + 1 < n ? i + 1 : i;
    int j1 = j + 1 < n ? j + 1 : j;
    float d00 = vs_lgrid_column_depth(VS_DATA_ARG(lgrid_data) grid, i, j, k, fr);
    float d10 = vs_lgrid_column_depth(VS_DATA_ARG(lgrid_data) grid, i1, j, k, fr);
    float d01 = vs_lgrid_column_depth(VS_DATA_ARG(lgrid_data) grid, i, j1, k, fr);
    float d11 = vs_lgrid_column_depth(VS_DATA_ARG(lgrid_data) grid, i1, j1, k, fr);
    VS_PRECISE float d0 = d00 + fu * (d10 - d00);
    VS_PRECISE float d1 = d01 + fu * (d11 - d01);
    VS_PRECISE float d = d0 + fv * (d1 - d0);
    return d;
}

/* Optical depth towards the light of grid `grid` at index-space point p. */
VS_FUNC float vs_lgrid_depth(VS_DATA_PARAM(vs_vec4, medium_data)
                                 VS_DATA_PARAM(vs_uint, lgrid_data) int grid,
                             pnanovdb_vec3_t p)
{
    if (vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_KIND) == VS_LGRID_RADIAL)
        return vs_lgrid_radial_depth(VS_DATA_ARG(medium_data) VS_DATA_ARG(lgrid_data) grid, p);
    return vs_lgrid_dir_depth(VS_DATA_ARG(lgrid_data) grid, p);
}

#endif
