#include "vdbscatter/lightgrid.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_lightgrid.h"

/* Word offsets are 32-bit (GLSL uint): a set holds at most this many words. */
#define MAX_WORDS ((int64_t)0xffffffffu)
/* Octahedral texels per side at most (a point light far from a huge volume). */
#define MAX_RESOLUTION 4096
/* Samples of one sweep tile: under llvmpipe's 128 MiB storage-buffer limit with room to
 * spare, and a bounded scratch on the C path. */
#define TILE_SAMPLES ((int64_t)1 << 24)
/* vdbs_light_grids_estimate plans no grid whose brick map and column records alone exceed
 * this (1 TiB): it reports that size as the need instead of allocating toward it. */
#define PLAN_MAX_BYTES 1099511627776.0

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The smallest world length of the three index axes. */
static double min_voxel_length(const vdbs_volume *volume)
{
    double best = HUGE_VAL;
    for (int a = 0; a < 3; ++a) {
        const double(*m)[4] = volume->index_to_world;
        best = fmin(best, sqrt(m[0][a] * m[0][a] + m[1][a] * m[1][a] + m[2][a] * m[2][a]));
    }
    return best;
}

static int oversample_of(const vdbs_light_grid_desc *desc)
{
    return desc && desc->oversample > 0 ? desc->oversample : VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
}

static void put_float(uint32_t *words, size_t at, double value)
{
    float f = (float)value;
    memcpy(words + at, &f, sizeof f);
}

static void put_vec3(uint32_t *words, size_t at, const double v[3])
{
    for (int a = 0; a < 3; ++a)
        put_float(words, at + (size_t)a, v[a]);
}

/* One grid's geometry before its sweep. */
typedef struct grid_plan {
    uint32_t kind;
    int64_t n[3];
    double spacing;
    double origin[3]; /* index space */
    double step_u[3], step_v[3], travel[3];
    double to_grid[3][3];
    double *radius; /* radial: n[2] shell radii */
    uint32_t *live; /* directional: a bit per column that may meet density (vs_lightgrid.h) */
} grid_plan;

/* Bricks of BRICK^3 voxels that hold output voxels, over the support box. */
#define BRICK 8

/* Marks the columns whose line may meet density: those within the footprint of a brick that
 * holds output voxels (the active region dilated by one, where the interpolant can be
 * non-zero), each brick taken as the index box [b, b + BRICK] (a cell whose lowest corner is
 * in the brick reaches one voxel beyond it), grown by a column for rounding. */
static vdbs_status mark_live_columns(const vdbs_volume *volume, grid_plan *g, vdbs_error *err)
{
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    int64_t b0[3], nb[3];
    for (int a = 0; a < 3; ++a) {
        b0[a] = (int64_t)floor(lo[a] / BRICK);
        nb[a] = (int64_t)floor(hi[a] / BRICK) - b0[a] + 1;
    }
    uint8_t *brick = calloc((size_t)(nb[0] * nb[1] * nb[2]), 1);
    int64_t columns = g->n[0] * g->n[1];
    g->live = calloc((size_t)((columns + 31) / 32), sizeof *g->live);
    if (!brick || !g->live) {
        free(brick);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    }
    for (size_t v = 0; v < volume->coord_count; ++v) {
        const int32_t *c = volume->coords + 3 * v;
        int64_t at[3];
        for (int a = 0; a < 3; ++a)
            at[a] = (int64_t)floor((double)c[a] / BRICK) - b0[a];
        if (at[0] >= 0 && at[1] >= 0 && at[2] >= 0 && at[0] < nb[0] && at[1] < nb[1] &&
            at[2] < nb[2])
            brick[(at[2] * nb[1] + at[1]) * nb[0] + at[0]] = 1;
    }
    for (int64_t z = 0; z < nb[2]; ++z)
        for (int64_t y = 0; y < nb[1]; ++y)
            for (int64_t x = 0; x < nb[0]; ++x) {
                if (!brick[(z * nb[1] + y) * nb[0] + x])
                    continue;
                const int64_t b[3] = {(b0[0] + x) * BRICK, (b0[1] + y) * BRICK,
                                      (b0[2] + z) * BRICK};
                double umin = HUGE_VAL, umax = -HUGE_VAL, vmin = HUGE_VAL, vmax = -HUGE_VAL;
                for (int corner = 0; corner < 8; ++corner) {
                    double d[3];
                    for (int a = 0; a < 3; ++a)
                        d[a] = (double)b[a] + ((corner >> a) & 1 ? BRICK : 0) - g->origin[a];
                    double u = dot3(g->to_grid[0], d), w = dot3(g->to_grid[1], d);
                    umin = fmin(umin, u);
                    umax = fmax(umax, u);
                    vmin = fmin(vmin, w);
                    vmax = fmax(vmax, w);
                }
                int64_t i0 = (int64_t)floor(umin) - 1, i1 = (int64_t)ceil(umax) + 1;
                int64_t j0 = (int64_t)floor(vmin) - 1, j1 = (int64_t)ceil(vmax) + 1;
                i0 = i0 < 0 ? 0 : i0;
                j0 = j0 < 0 ? 0 : j0;
                i1 = i1 >= g->n[0] ? g->n[0] - 1 : i1;
                j1 = j1 >= g->n[1] ? g->n[1] - 1 : j1;
                for (int64_t j = j0; j <= j1; ++j)
                    for (int64_t i = i0; i <= i1; ++i) {
                        int64_t column = j * g->n[0] + i;
                        g->live[column / 32] |= 1u << (column % 32);
                    }
            }
    free(brick);
    return VDBS_OK;
}

/* mark 0: the shape and frame only, no live bits (vdbs_light_grids_estimate sizes them
 * first). */
static vdbs_status plan_directional(const vdbs_volume *volume, const double travel[3],
                                    double spacing, int mark, grid_plan *g, vdbs_error *err)
{
    double len = sqrt(dot3(travel, travel));
    if (!(len > 0.0) || !isfinite(len))
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "light grid: zero direction");
    double axes[3][3];
    for (int a = 0; a < 3; ++a)
        axes[2][a] = travel[a] / len;
    vdbs_ortho_basis(axes[2], axes[0], axes[1]);
    g->kind = VS_LGRID_DIRECTIONAL;
    g->spacing = spacing;
    /* The corners in the frame, relative to the box's lowest corner (a voxel centre), so that
     * aligned samples fall on voxel centres. */
    double corners[8][3];
    vdbs_volume_support_corners(volume, corners);
    double cmin[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, cmax[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int corner = 0; corner < 8; ++corner) {
        double d[3];
        for (int a = 0; a < 3; ++a)
            d[a] = corners[corner][a] - corners[0][a];
        for (int a = 0; a < 3; ++a) {
            double c = dot3(d, axes[a]) / g->spacing;
            cmin[a] = fmin(cmin[a], c);
            cmax[a] = fmax(cmax[a], c);
        }
    }
    /* Round outwards, with a hair of slack so that corners on a sample stay on it. */
    double first[3];
    for (int a = 0; a < 3; ++a) {
        first[a] = floor(cmin[a] + 1e-9);
        double count = ceil(cmax[a] - 1e-9) - first[a] + 1.0;
        if (count > 1e9)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "light grid: %g samples along an axis",
                                  count);
        g->n[a] = (int64_t)count;
    }
    double origin[3];
    for (int a = 0; a < 3; ++a)
        origin[a] = corners[0][a] + g->spacing * (first[0] * axes[0][a] + first[1] * axes[1][a] +
                                                  first[2] * axes[2][a]);
    vdbs_volume_index_point(volume, origin, g->origin);
    double step[3];
    for (int a = 0; a < 3; ++a)
        step[a] = axes[0][a] * g->spacing;
    vdbs_volume_index_vector(volume, step, g->step_u);
    for (int a = 0; a < 3; ++a)
        step[a] = axes[1][a] * g->spacing;
    vdbs_volume_index_vector(volume, step, g->step_v);
    vdbs_volume_index_vector(volume, axes[2], g->travel);
    /* Index offset -> grid coordinates: (axis . (M d)) / h, M the index-to-world linear part. */
    const double(*m)[4] = volume->index_to_world;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            g->to_grid[r][c] =
                (axes[r][0] * m[0][c] + axes[r][1] * m[1][c] + axes[r][2] * m[2][c]) / g->spacing;
    return mark ? mark_live_columns(volume, g, err) : VDBS_OK;
}

static vdbs_status plan_radial(const vdbs_volume *volume, const double position[3], int F,
                               grid_plan *g, vdbs_error *err)
{
    g->kind = VS_LGRID_RADIAL;
    double h = min_voxel_length(volume) / F;
    double corners[8][3], r_max = 0.0;
    vdbs_volume_support_corners(volume, corners);
    for (int corner = 0; corner < 8; ++corner) {
        double d[3];
        for (int a = 0; a < 3; ++a)
            d[a] = corners[corner][a] - position[a];
        r_max = fmax(r_max, sqrt(dot3(d, d)));
    }
    /* Texels of about h at r_max: an octahedral texel spans up to pi / resolution radians. */
    double resolution = fmin(fmax(ceil(VDBS_PI * r_max / h), 8.0), MAX_RESOLUTION);
    double texel = VDBS_PI / resolution;
    /* Shells h apart, or a texel's width apart where that is wider; the last beyond r_max. */
    int64_t shells = 1;
    for (double r = 0.0; r < r_max; r += fmax(h, texel * r))
        ++shells;
    g->radius = malloc(sizeof *g->radius * (size_t)shells);
    if (!g->radius)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    g->radius[0] = 0.0;
    for (int64_t k = 1; k < shells; ++k)
        g->radius[k] = g->radius[k - 1] + fmax(h, texel * g->radius[k - 1]);
    g->n[0] = g->n[1] = (int64_t)resolution;
    g->n[2] = shells;
    vdbs_volume_index_point(volume, position, g->origin);
    return VDBS_OK;
}

static void header_write(uint32_t *words, int grid, const grid_plan *g, size_t columns_at,
                         size_t radii_at, size_t live_at)
{
    size_t h = vs_lgrid_header(grid);
    words[h + VS_LGRID_OFF_KIND] = g->kind;
    for (int a = 0; a < 3; ++a)
        words[h + VS_LGRID_OFF_N + (size_t)a] = (uint32_t)g->n[a];
    words[h + VS_LGRID_OFF_COLUMNS] = (uint32_t)columns_at;
    words[h + VS_LGRID_OFF_RADII] = (uint32_t)radii_at;
    words[h + VS_LGRID_OFF_LIVE] = g->live ? (uint32_t)live_at : 0u;
    if (g->live)
        memcpy(words + live_at, g->live, sizeof *g->live * (size_t)((g->n[0] * g->n[1] + 31) / 32));
    put_float(words, h + VS_LGRID_OFF_SPACING, g->spacing);
    put_vec3(words, h + VS_LGRID_OFF_ORIGIN, g->origin);
    put_vec3(words, h + VS_LGRID_OFF_STEP_U, g->step_u);
    put_vec3(words, h + VS_LGRID_OFF_STEP_V, g->step_v);
    put_vec3(words, h + VS_LGRID_OFF_TRAVEL, g->travel);
    for (int r = 0; r < 3; ++r)
        put_vec3(words, h + VS_LGRID_OFF_TO_GRID + 3 * (size_t)r, g->to_grid[r]);
    for (int64_t k = 0; g->radius && k < g->n[2]; ++k)
        put_float(words, radii_at + (size_t)k, g->radius[k]);
}

/* ---- the sweep, tile by tile ---- */

typedef struct sweep_job {
    const vdbs_volume *volume;
    const float *medium;
    const uint32_t *words; /* count, headers and radii */
    int grid;
    int64_t first_column; /* of the tile */
    int64_t n0, n2;
    float *out; /* the tile: n2 samples per column */
} sweep_job;

static void sweep_items(void *user, uint64_t begin, uint64_t end)
{
    const sweep_job *job = user;
    pnanovdb_buf_t buf = pnanovdb_make_buf(job->volume->nano, job->volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    for (uint64_t item = begin; item < end; ++item) {
        int64_t column = job->first_column + (int64_t)item;
        vs_lgrid_sweep_column((const vs_vec4 *)job->medium, job->words, job->out, buf, &acc,
                              job->grid, (int)(column % job->n0), (int)(column / job->n0),
                              (vs_uint)(item * (uint64_t)job->n2));
    }
}

/* Growing storage of the packed depth samples. */
typedef struct depth_store {
    float *data;
    int64_t count, capacity;
} depth_store;

static int store_reserve(depth_store *s, int64_t more)
{
    if (s->count + more <= s->capacity)
        return 1;
    int64_t cap = s->capacity ? s->capacity : 1 << 16;
    while (cap < s->count + more)
        cap *= 2;
    float *grown = realloc(s->data, sizeof *grown * (size_t)cap);
    if (!grown)
        return 0;
    s->data = grown;
    s->capacity = cap;
    return 1;
}

/* Keeps of each swept column only the stretch where its depth changes (vs_lightgrid.h):
 * records[3 c + ...] get the offset relative to the store's start, the first stored sample
 * and the count. */
static int tile_pack(const float *tile, int64_t columns, int64_t n2, uint32_t *records,
                     depth_store *store, int64_t *empty)
{
    int64_t *first = malloc(sizeof *first * (size_t)columns * 2);
    if (!first)
        return 0;
    int64_t *count = first + columns;
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < columns; ++c) {
        const float *d = tile + c * n2;
        if (d[0] == VS_LGRID_SKIPPED) {
            first[c] = count[c] = 0;
            continue;
        }
        int64_t k0 = 0;
        while (k0 < n2 && d[k0] == 0.0f)
            ++k0;
        int64_t k1 = n2 - 1;
        while (k1 > k0 && d[k1 - 1] == d[n2 - 1])
            --k1;
        first[c] = k0;
        count[c] = k0 < n2 ? k1 - k0 + 1 : 0;
    }
    int64_t total = 0;
    for (int64_t c = 0; c < columns; ++c) {
        int64_t n = count[c];
        count[c] = total; /* now the offset within this tile's stretch */
        total += n;
        records[VS_LGRID_COLUMN_WORDS * c + VS_LGRID_COLUMN_FIRST] = (uint32_t)first[c];
        records[VS_LGRID_COLUMN_WORDS * c + VS_LGRID_COLUMN_COUNT] = (uint32_t)n;
        records[VS_LGRID_COLUMN_WORDS * c + VS_LGRID_COLUMN_OFFSET] =
            (uint32_t)(store->count + count[c]);
        *empty += n == 0;
    }
    if (!store_reserve(store, total)) {
        free(first);
        return 0;
    }
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < columns; ++c) {
        int64_t n = records[VS_LGRID_COLUMN_WORDS * c + VS_LGRID_COLUMN_COUNT];
        if (n > 0)
            memcpy(store->data + store->count + count[c], tile + c * n2 + first[c],
                   sizeof *tile * (size_t)n);
    }
    store->count += total;
    free(first);
    return 1;
}

/* Columns of grid g per sweep tile. */
static int64_t tile_columns(const grid_plan *g)
{
    int64_t columns = g->n[0] * g->n[1];
    int64_t per_tile = TILE_SAMPLES / g->n[2] > 0 ? TILE_SAMPLES / g->n[2] : 1;
    return per_tile < columns ? per_tile : columns;
}

/* Sweeps grid g tile by tile into `tile` (room for tile_columns(g) columns). */
static vdbs_status sweep_grid(vdbs_runner *runner, const vdbs_volume *volume, const float *medium,
                              const uint32_t *words, size_t prefix_words, int grid,
                              const grid_plan *g, float *tile, uint32_t *records,
                              depth_store *store, int64_t *empty, vdbs_error *err)
{
    int64_t columns = g->n[0] * g->n[1];
    int64_t per_tile = tile_columns(g);
    sweep_job job = {volume, medium, words, grid, 0, g->n[0], g->n[2], tile};
    uint32_t params[4] = {(uint32_t)grid, 0, 0, 0};
    vdbs_status st = VDBS_OK;
    for (int64_t c0 = 0; c0 < columns && st == VDBS_OK; c0 += per_tile) {
        int64_t n = columns - c0 < per_tile ? columns - c0 : per_tile;
        job.first_column = c0;
        params[1] = (uint32_t)c0;
        vdbs_kernel_desc desc = {0};
        desc.items = (uint64_t)n;
        desc.user = &job;
        desc.cpu_items = sweep_items;
        desc.cpu_chunk = 16;
        desc.shader = "lightgrid_sweep.comp";
        desc.inputs[0] = (vdbs_kernel_input){.data = volume->nano, .size = volume->nano_size};
        desc.inputs[1] =
            (vdbs_kernel_input){.data = medium, .size = sizeof(float) * 4 * VS_MEDIUM_SIZE};
        desc.inputs[2] = (vdbs_kernel_input){.data = words, .size = sizeof *words * prefix_words};
        desc.inputs[3] = (vdbs_kernel_input){.data = params, .size = sizeof params};
        desc.output_words = (size_t)g->n[2];
        desc.output = tile;
        desc.units_per_dispatch = 1;
        desc.total_units = 1;
        st = vdbs_kernel_run(runner, &desc, NULL, err);
        if (st == VDBS_OK &&
            !tile_pack(tile, n, g->n[2], records + VS_LGRID_COLUMN_WORDS * c0, store, empty))
            st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light grid");
    }
    return st;
}

void vdbs_light_grids_free(vdbs_light_grids *grids)
{
    if (!grids)
        return;
    free(grids->words);
    memset(grids, 0, sizeof *grids);
}

/* The share of the light arriving at the volume's centre that light l carries (colours
 * summed over the channels; a point light's at the centre's distance). */
static double light_share(const vdbs_volume *volume, const vdbs_light_table *lights, int l)
{
    double corners[8][3], centre[3];
    vdbs_volume_support_corners(volume, corners);
    for (int a = 0; a < 3; ++a)
        centre[a] = 0.5 * (corners[0][a] + corners[7][a]);
    double total = 0.0, own = 0.0;
    for (int k = 0; k < lights->direct_count + lights->ordinate_count; ++k) {
        double color[3], travel[3];
        vdbs_lights_arrival(lights, k, centre, color, travel);
        double p = fabs(color[0]) + fabs(color[1]) + fabs(color[2]);
        total += p;
        own += k == l ? p : 0.0;
    }
    return total > 0.0 ? own / total : 1.0;
}

/* Sky ordinate l's spacing (world): desc's, or by the sky's share of the light
 * (lightgrid.h). */
static double sky_spacing(const vdbs_volume *volume, const vdbs_light_table *lights, int l,
                          double h, const vdbs_light_grid_desc *desc)
{
    double voxel = min_voxel_length(volume);
    if (desc && desc->sky_spacing < 0.0)
        return h;
    if (desc && desc->sky_spacing > 0.0)
        return voxel * desc->sky_spacing;
    double share = light_share(volume, lights, l) * lights->ordinate_count;
    double s = share > 0.0 ? sqrt(VDBS_LIGHT_GRID_SKY_SHARE / share) : VDBS_LIGHT_GRID_SKY_MAX;
    return fmax(h, voxel * fmin(s, VDBS_LIGHT_GRID_SKY_MAX));
}

/* One plan per light of [first, first + count): a point light's grid is radial, a sun's or
 * sky ordinate's directional (sky light travels away from its sky). */
static vdbs_status plan_grids(const vdbs_volume *volume, const vdbs_light_table *lights, int first,
                              int count, const vdbs_light_grid_desc *desc, int mark,
                              grid_plan *plans, vdbs_error *err)
{
    const int F = oversample_of(desc);
    const double h = min_voxel_length(volume) / F;
    vdbs_status st = VDBS_OK;
    for (int g = 0; g < count && st == VDBS_OK; ++g) {
        int l = first + g;
        if (l < lights->direct_count && lights->direct[l].type == VDBS_LIGHT_POINT) {
            st = plan_radial(volume, lights->direct[l].world, F, &plans[g], err);
        } else if (l < lights->direct_count) {
            st = plan_directional(volume, lights->direct[l].world, h, mark, &plans[g], err);
        } else {
            const double *w = lights->ordinates[l - lights->direct_count].world;
            double travel[3] = {-w[0], -w[1], -w[2]}; /* sky light travels away from its sky */
            st = plan_directional(volume, travel, sky_spacing(volume, lights, l, h, desc), mark,
                                  &plans[g], err);
        }
    }
    return st;
}

static void plans_free(grid_plan *plans, int count)
{
    for (int g = 0; g < count; ++g) {
        free(plans[g].radius);
        free(plans[g].live);
    }
    free(plans);
}

/* Where each grid's parts sit in the set's words. Layout: count and headers, radii and
 * live bits (what the sweep reads: the first `prefix` words), column records, then the
 * depth samples from depth_at. */
typedef struct grid_layout {
    int64_t *radii_at, *columns_at, *live_at; /* per grid, one allocation */
    int64_t prefix, depth_at;
} grid_layout;

/* Also counts the grids' columns and cells into stats. */
static vdbs_status layout_grids(const grid_plan *plans, int count, grid_layout *lay,
                                vdbs_light_grid_stats *stats, vdbs_error *err)
{
    int64_t at = VS_LGRIDS_OFF_HEADERS + (int64_t)count * VS_LGRID_WORDS;
    int slots = count > 0 ? count : 1;
    lay->radii_at = calloc((size_t)slots, 3 * sizeof *lay->radii_at);
    if (!lay->radii_at)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for light grids");
    lay->columns_at = lay->radii_at + slots;
    lay->live_at = lay->radii_at + 2 * slots;
    for (int g = 0; g < count; ++g) {
        lay->radii_at[g] = at;
        at += plans[g].kind == VS_LGRID_RADIAL ? plans[g].n[2] : 0;
        lay->live_at[g] = at;
        at += plans[g].live ? (plans[g].n[0] * plans[g].n[1] + 31) / 32 : 0;
    }
    lay->prefix = at;
    for (int g = 0; g < count; ++g) {
        lay->columns_at[g] = at;
        at += VS_LGRID_COLUMN_WORDS * plans[g].n[0] * plans[g].n[1];
        stats->columns += plans[g].n[0] * plans[g].n[1];
        stats->cells += plans[g].n[0] * plans[g].n[1] * plans[g].n[2];
        if (plans[g].kind == VS_LGRID_DIRECTIONAL) {
            double h = plans[g].spacing;
            stats->spacing_min = stats->spacing_min > 0.0 ? fmin(stats->spacing_min, h) : h;
            stats->spacing_max = fmax(stats->spacing_max, h);
        }
    }
    lay->depth_at = at;
    if (lay->depth_at > MAX_WORDS)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "light grids of %lld columns are too large; lower the oversample",
                              (long long)stats->columns);
    return VDBS_OK;
}

/* The set's words before the depth samples: the count, the filter across columns and
 * every grid's header (radii and live bits included); the records are filled by the
 * sweeps. */
static vdbs_status words_begin(const grid_plan *plans, int count, const vdbs_light_grid_desc *desc,
                               const grid_layout *lay, uint32_t **words, vdbs_error *err)
{
    uint32_t *w = calloc((size_t)lay->depth_at, sizeof *w);
    if (!w)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for light grids");
    w[VS_LGRIDS_OFF_COUNT] = (uint32_t)count;
    w[VS_LGRIDS_OFF_ACROSS] =
        desc && desc->bilinear ? VS_LGRID_ACROSS_BILINEAR : VS_LGRID_ACROSS_CATMULL_ROM;
    for (int g = 0; g < count; ++g)
        header_write(w, g, &plans[g], (size_t)lay->columns_at[g], (size_t)lay->radii_at[g],
                     (size_t)lay->live_at[g]);
    *words = w;
    return VDBS_OK;
}

/* Sweeps every grid into its column records and the store, through one tile for all grids
 * (the largest any of them needs); counts the empty columns. */
static vdbs_status sweep_grids(vdbs_runner *runner, const vdbs_volume *volume,
                               const grid_plan *plans, int count, const grid_layout *lay,
                               uint32_t *words, depth_store *store, vdbs_light_grids *out,
                               vdbs_error *err)
{
    int64_t tile_samples = 1;
    for (int g = 0; g < count; ++g)
        if (tile_columns(&plans[g]) * plans[g].n[2] > tile_samples)
            tile_samples = tile_columns(&plans[g]) * plans[g].n[2];
    float *tile = malloc(sizeof *tile * (size_t)tile_samples);
    if (!tile)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a light-grid tile");
    vdbs_status st = VDBS_OK;
    for (int g = 0; g < count && st == VDBS_OK; ++g)
        st = sweep_grid(runner, volume, out->medium, words, (size_t)lay->prefix, g, &plans[g], tile,
                        words + lay->columns_at[g], store, &out->stats.columns_empty, err);
    free(tile);
    return st;
}

/* Appends the stored samples after the records (*words grows) and makes the records'
 * offsets, relative to the store until now, absolute. */
static vdbs_status append_depths(const grid_plan *plans, int count, const grid_layout *lay,
                                 const depth_store *store, uint32_t **words, vdbs_error *err)
{
    const int64_t depth_at = lay->depth_at;
    if (depth_at + store->count > MAX_WORDS)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "light grids of %lld stored samples are too large; lower the "
                              "oversample",
                              (long long)store->count);
    uint32_t *grown = realloc(*words, sizeof **words * (size_t)(depth_at + store->count));
    if (!grown)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for light grids");
    *words = grown;
    if (store->count > 0) /* every column empty: no samples, store->data NULL */
        memcpy(grown + depth_at, store->data, sizeof *store->data * (size_t)store->count);
    for (int g = 0; g < count; ++g)
        for (int64_t c = 0; c < plans[g].n[0] * plans[g].n[1]; ++c)
            grown[lay->columns_at[g] + VS_LGRID_COLUMN_WORDS * c + VS_LGRID_COLUMN_OFFSET] +=
                (uint32_t)depth_at;
    return VDBS_OK;
}

vdbs_status vdbs_light_grids_build(vdbs_runner *runner, const vdbs_volume *volume,
                                   const vdbs_scene *scene, const vdbs_light_table *lights,
                                   int first, int count, const vdbs_light_grid_desc *desc,
                                   vdbs_light_grids *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    if (first < 0 || count < 0 || first + count > lights->direct_count + lights->ordinate_count)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "light grids: lights %d..%d of %d", first,
                              first + count, lights->direct_count + lights->ordinate_count);
    double t0 = omp_get_wtime();
    vdbs_medium medium;
    vdbs_medium_init(&medium, volume, scene);
    vdbs_medium_pack(&medium, out->medium);
    grid_plan *plans = calloc((size_t)(count > 0 ? count : 1), sizeof *plans);
    if (!plans)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for light grids");
    grid_layout lay = {0};
    uint32_t *words = NULL;
    depth_store store = {NULL, 0, 0};
    vdbs_status st = plan_grids(volume, lights, first, count, desc, 1, plans, err);
    if (st == VDBS_OK)
        st = layout_grids(plans, count, &lay, &out->stats, err);
    if (st == VDBS_OK)
        st = words_begin(plans, count, desc, &lay, &words, err);
    if (st == VDBS_OK)
        st = sweep_grids(runner, volume, plans, count, &lay, words, &store, out, err);
    if (st == VDBS_OK)
        st = append_depths(plans, count, &lay, &store, &words, err);
    free(store.data);
    plans_free(plans, count);
    free(lay.radii_at);
    if (st != VDBS_OK) {
        free(words);
        memset(out, 0, sizeof *out);
        return st;
    }
    out->words = words;
    out->word_count = (size_t)(lay.depth_at + store.count);
    out->count = count;
    out->stats.stored = store.count;
    out->stats.seconds_sweep = omp_get_wtime() - t0;
    return VDBS_OK;
}

/* Bricks of the support box that hold output voxels (mark_live_columns' bricks, at
 * multiples of BRICK like the volume's leaves), and the bytes of its brick map. */
static int64_t occupied_bricks(const vdbs_volume *volume, int64_t *map_bytes)
{
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    *map_bytes = 1;
    for (int a = 0; a < 3; ++a)
        *map_bytes *= (int64_t)floor(hi[a] / BRICK) - (int64_t)floor(lo[a] / BRICK) + 1;
    int64_t count = vdbs_volume_leaf_count(volume);
    return count < *map_bytes ? count : *map_bytes;
}

/* The bytes vdbs_light_grids_build holds resident at its peak for a set of `words` words
 * before the samples, a sweep tile of `tile` samples over `tile_cols` columns and `samples`
 * stored samples: tile_pack's offsets take 16 bytes a column, and append_depths grows the
 * words by the samples while the store is still held. The store's capacity beyond its count
 * (store_reserve doubles it) is never written, so never resident; mark_live_columns' brick
 * map of `map_bytes` comes and goes before. */
static int64_t build_peak(int64_t words, int64_t tile, int64_t tile_cols, int64_t samples,
                          int64_t map_bytes)
{
    const int64_t word = (int64_t)sizeof(uint32_t);
    int64_t sweeping = word * (words + tile + samples) + 16 * tile_cols;
    int64_t appending = word * (words + 2 * samples);
    int64_t most = sweeping > appending ? sweeping : appending;
    return most > map_bytes ? most : map_bytes;
}

vdbs_status vdbs_light_grids_estimate(const vdbs_volume *volume, const vdbs_light_table *lights,
                                      int first, int count, const vdbs_light_grid_desc *desc,
                                      vdbs_light_grids_memory *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    if (volume->coord_count == 0 || count <= 0)
        return VDBS_OK;
    int64_t map_bytes = 0;
    const int64_t bricks = occupied_bricks(volume, &map_bytes);
    /* The voxels a grid's cells cover: a directional grid's, the output voxels (its stored
     * stretches hug the density: measured 1.10-1.23 of the stored samples on the procedural
     * cloud and smoke, tests/test_memory.c); a radial grid's, the occupied bricks' (its cells
     * near the light are finer than h, so the voxels alone fall short, 0.4; the bricks'
     * 0.86-1.28). */
    const double voxels = (double)volume->coord_count;
    const double in_bricks = (double)bricks * BRICK * BRICK * BRICK;
    const double voxel = min_voxel_length(volume);
    int64_t words = VS_LGRIDS_OFF_HEADERS + (int64_t)count * VS_LGRID_WORDS, tile = 1,
            tile_cols = 1;
    int64_t samples = 0, plan_bytes = 0;
    /* One plan at a time: the live bits of 1025 grids at once would be the estimate's own
     * peak. */
    for (int g = 0; g < count; ++g) {
        grid_plan plan;
        memset(&plan, 0, sizeof plan);
        const int64_t words_before = words, plan_before = plan_bytes;
        vdbs_status st = plan_grids(volume, lights, first + g, 1, desc, 0, &plan, err);
        int64_t columns = plan.n[0] * plan.n[1], live = columns;
        /* A plan whose own brick map and live bits (or records) are beyond any memory: that
         * alone is the need, before allocating either. */
        double records = (double)plan.n[0] * (double)plan.n[1] *
                         (VS_LGRID_COLUMN_WORDS * sizeof(uint32_t) + 1.0 / 8.0);
        if (st == VDBS_OK && (double)map_bytes + records > PLAN_MAX_BYTES) {
            free(plan.radius);
            out->peak = out->peak_one = out->held =
                (int64_t)fmin((double)map_bytes + records, (double)INT64_MAX / 4);
            out->columns = columns;
            out->cells = (int64_t)fmin((double)columns * (double)plan.n[2], (double)INT64_MAX / 4);
            return VDBS_OK;
        }
        if (st == VDBS_OK && plan.kind == VS_LGRID_DIRECTIONAL)
            st = mark_live_columns(volume, &plan, err);
        if (st != VDBS_OK) {
            free(plan.radius);
            free(plan.live);
            return st;
        }
        if (plan.live) {
            live = 0;
            for (int64_t w = 0; w < (columns + 31) / 32; ++w)
                live += __builtin_popcount(plan.live[w]);
        }
        /* the layout's words, as layout_grids counts them */
        int64_t live_words = plan.live ? (columns + 31) / 32 : 0;
        words += (plan.kind == VS_LGRID_RADIAL ? plan.n[2] : 0) + live_words +
                 VS_LGRID_COLUMN_WORDS * columns;
        plan_bytes += (int64_t)sizeof(uint32_t) * live_words +
                      (int64_t)sizeof(double) * (plan.kind == VS_LGRID_RADIAL ? plan.n[2] : 0);
        /* Stored: a live column keeps the stretch where its depth changes, at most its n2
         * samples; together about the cells of what the grid covers (above; cells of the
         * grid's spacing, or a radial grid's h). */
        double h = plan.kind == VS_LGRID_RADIAL ? voxel / oversample_of(desc) : plan.spacing;
        double covered = (plan.kind == VS_LGRID_RADIAL ? in_bricks : voxels) * pow(voxel / h, 3.0);
        double stored = fmin((double)live * (double)plan.n[2], covered);
        samples += (int64_t)stored;
        out->columns += columns;
        out->cells += (int64_t)fmin((double)columns * (double)plan.n[2], (double)INT64_MAX / 4);
        if (tile_columns(&plan) * plan.n[2] > tile) {
            tile = tile_columns(&plan) * plan.n[2];
            tile_cols = tile_columns(&plan);
        }
        /* this grid built on its own (vdbs_light_grids_build with count 1) */
        int64_t own = build_peak(VS_LGRIDS_OFF_HEADERS + VS_LGRID_WORDS + words - words_before,
                                 tile_columns(&plan) * plan.n[2], tile_columns(&plan),
                                 (int64_t)stored, map_bytes) +
                      plan_bytes - plan_before;
        out->peak_one = own > out->peak_one ? own : out->peak_one;
        free(plan.radius);
        free(plan.live);
    }
    out->samples = samples;
    out->held = (int64_t)sizeof(uint32_t) * (words + samples);
    out->peak = plan_bytes + build_peak(words, tile, tile_cols, samples, map_bytes);
    return VDBS_OK;
}

vdbs_status vdbs_light_grids_fit(vdbs_runner *runner, const vdbs_light_grids *grids,
                                 vdbs_error *err)
{
    if (vdbs_runner_backend(runner) != VDBS_BACKEND_GPU)
        return VDBS_OK;
    int64_t limit = vdbs_gpu_get_info(vdbs_runner_gpu(runner))->max_ssbo_bytes;
    size_t bytes = sizeof *grids->words * grids->word_count;
    if ((int64_t)bytes <= limit)
        return VDBS_OK;
    return vdbs_error_set(err, VDBS_ERR_GPU,
                          "%zu MiB of light grids exceed the GPU's %lld MiB storage-buffer limit; "
                          "lower --s1-oversample or --quality, or use --backend cpu",
                          bytes >> 20, (long long)(limit >> 20));
}

void vdbs_light_grids_shape(const vdbs_light_grids *grids, int grid, int n[3])
{
    for (int a = 0; a < 3; ++a)
        n[a] = vs_lgrid_n(grids->words, grid, a);
}

float vdbs_light_grids_sample(const vdbs_light_grids *grids, int grid, int i, int j, int k)
{
    return vs_lgrid_column_depth(grids->words, grid, i, j, k, 0.0f);
}

/* Column (i, j)'s stored stretch [first, end); end 0 for an empty column. */
static void column_span(const vdbs_light_grids *grids, int grid, int i, int j, int *first, int *end)
{
    vs_uint record = vs_lgrid_record(grids->words, grid, i, j);
    int count = (int)grids->words[record + VS_LGRID_COLUMN_COUNT];
    *first = (int)grids->words[record + VS_LGRID_COLUMN_FIRST];
    *end = count > 0 ? *first + count : 0;
}

void vdbs_light_grid_samples_free(vdbs_light_grid_samples *samples)
{
    free(samples->coords);
    free(samples->values);
    free(samples->radii);
    memset(samples, 0, sizeof *samples);
}

vdbs_status vdbs_light_grids_samples(const vdbs_light_grids *grids, int grid,
                                     vdbs_light_grid_samples *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    int n[3];
    vdbs_light_grids_shape(grids, grid, n);
    /* Two passes: count, then fill. */
    for (int pass = 0; pass < 2; ++pass) {
        size_t at = 0;
        for (int j = 0; j < n[1]; ++j)
            for (int i = 0; i < n[0]; ++i) {
                int first, end, reach = 0;
                column_span(grids, grid, i, j, &first, &end);
                if (end == 0)
                    continue;
                for (int b = j - 1; b <= j + 1; ++b)
                    for (int a = i - 1; a <= i + 1; ++a) {
                        int f, e;
                        if (a < 0 || b < 0 || a >= n[0] || b >= n[1])
                            continue;
                        column_span(grids, grid, a, b, &f, &e);
                        reach = e > reach ? e : reach;
                    }
                reach = reach + 1 < n[2] ? reach + 1 : n[2];
                for (int k = first; k < reach; ++k, ++at) {
                    if (pass == 0)
                        continue;
                    out->coords[3 * at] = i;
                    out->coords[3 * at + 1] = j;
                    out->coords[3 * at + 2] = k;
                    out->values[at] = vdbs_light_grids_sample(grids, grid, i, j, k);
                }
            }
        if (pass == 0) {
            out->count = at;
            out->coords = malloc(sizeof *out->coords * 3 * (at ? at : 1));
            out->values = malloc(sizeof *out->values * (at ? at : 1));
            if (!out->coords || !out->values) {
                vdbs_light_grid_samples_free(out);
                return vdbs_error_set(err, VDBS_ERR_NOMEM,
                                      "out of memory for %zu light-grid samples", at);
            }
        }
    }
    if (vs_lgrid_word(grids->words, grid, VS_LGRID_OFF_KIND) == VS_LGRID_RADIAL) {
        out->radial = 1;
        out->texels = n[0];
        out->shells = n[2];
        if (!(out->radii = malloc(sizeof *out->radii * (size_t)n[2]))) {
            vdbs_light_grid_samples_free(out);
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for shell radii");
        }
        vs_uint radii = vs_lgrid_word(grids->words, grid, VS_LGRID_OFF_RADII);
        for (int k = 0; k < n[2]; ++k)
            out->radii[k] = vs_word_float(grids->words[radii + (vs_uint)k]);
        for (int r = 0; r < 3; ++r)
            out->to_index[r][r] = 1.0;
        return VDBS_OK;
    }
    pnanovdb_vec3_t o = vs_lgrid_vec3(grids->words, grid, VS_LGRID_OFF_ORIGIN);
    pnanovdb_vec3_t u = vs_lgrid_vec3(grids->words, grid, VS_LGRID_OFF_STEP_U);
    pnanovdb_vec3_t v = vs_lgrid_vec3(grids->words, grid, VS_LGRID_OFF_STEP_V);
    pnanovdb_vec3_t w = vs_lgrid_vec3(grids->words, grid, VS_LGRID_OFF_TRAVEL);
    float h = vs_lgrid_float(grids->words, grid, VS_LGRID_OFF_SPACING);
    const double cols[4][3] = {{u.x, u.y, u.z},
                               {v.x, v.y, v.z},
                               {(double)h * w.x, (double)h * w.y, (double)h * w.z},
                               {o.x, o.y, o.z}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            out->to_index[r][c] = cols[c][r];
    return VDBS_OK;
}

float vdbs_light_grids_depth(const vdbs_light_grids *grids, int grid, const double index[3])
{
    return vs_lgrid_depth((const vs_vec4 *)grids->medium, grids->words, grid,
                          vs_vec3((float)index[0], (float)index[1], (float)index[2]));
}

/* ---- the lookup at every output voxel ---- */

typedef struct lookup_job {
    const vdbs_volume *volume;
    const vdbs_light_grids *grids;
    int grid;
    float *depth;
} lookup_job;

static void lookup_items(void *user, uint64_t begin, uint64_t end)
{
    const lookup_job *job = user;
    for (uint64_t n = begin; n < end; ++n) {
        const int32_t *c = job->volume->coords + 3 * n;
        job->depth[n] = vs_lgrid_depth((const vs_vec4 *)job->grids->medium, job->grids->words,
                                       job->grid, vs_vec3((float)c[0], (float)c[1], (float)c[2]));
    }
}

vdbs_status vdbs_light_grids_lookup_voxels(vdbs_runner *runner, const vdbs_volume *volume,
                                           const vdbs_light_grids *grids, int grid, float *depth,
                                           vdbs_error *err)
{
    if (volume->coord_count == 0)
        return VDBS_OK;
    vdbs_status st = vdbs_light_grids_fit(runner, grids, err);
    if (st != VDBS_OK)
        return st;
    lookup_job job = {volume, grids, grid, depth};
    uint32_t params[4] = {(uint32_t)grid, 0, 0, 0};
    vdbs_kernel_desc desc = {0};
    desc.items = volume->coord_count;
    desc.user = &job;
    desc.cpu_items = lookup_items;
    desc.cpu_chunk = 4096;
    desc.shader = "lightgrid_lookup.comp";
    desc.inputs[1] = (vdbs_kernel_input){.data = grids->medium, .size = sizeof grids->medium};
    desc.inputs[2] =
        (vdbs_kernel_input){.data = grids->words, .size = sizeof *grids->words * grids->word_count};
    desc.inputs[3] = (vdbs_kernel_input){.data = params, .size = sizeof params};
    desc.inputs[4] = (vdbs_kernel_input){.data = volume->coords,
                                         .size = 3 * sizeof(int32_t) * volume->coord_count};
    desc.output_words = 1;
    desc.output = depth;
    desc.total_units = 1;
    return vdbs_kernel_run(runner, &desc, NULL, err);
}
