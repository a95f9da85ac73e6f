#include "vdbscatter/medium.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"

_Static_assert(VDBS_MEDIUM_TABLE_ENTRIES == VS_MEDIUM_SIZE, "medium table size");

void vdbs_medium_init(vdbs_medium *medium, const vdbs_volume *volume, const vdbs_scene *scene)
{
    medium->volume = volume;
    medium->density_scale = scene->density_scale;
    memcpy(medium->albedo, scene->albedo, sizeof medium->albedo);
    medium->g = scene->g;
}

double vdbs_medium_sigma_t(const vdbs_medium *medium, const double index_point[3])
{
    const vdbs_volume *volume = medium->volume;
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    pnanovdb_vec3_t p =
        vs_vec3((float)index_point[0], (float)index_point[1], (float)index_point[2]);
    return vs_density_at(buf, &acc, p) * medium->density_scale;
}

/* ---- majorant grid ---- */

vdbs_status vdbs_majorant_grid_build(const vdbs_medium *medium, vdbs_majorant_grid *g,
                                     vdbs_error *err)
{
    const vdbs_volume *volume = medium->volume;
    const double density_scale = medium->density_scale;
    memset(g, 0, sizeof *g);
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    int ext[3];
    for (int a = 0; a < 3; ++a) {
        g->lo[a] = lo[a];
        g->hi[a] = hi[a];
        ext[a] = (int)(hi[a] - lo[a]);
    }
    g->block = VDBS_MAJORANT_BLOCK;
    for (;;) {
        for (int a = 0; a < 3; ++a)
            g->dims[a] = (ext[a] + g->block - 1) / g->block;
        if ((double)g->dims[0] * g->dims[1] * g->dims[2] <= VDBS_MAJORANT_MAX_CELLS)
            break;
        g->block *= 2;
    }
    size_t cells = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    g->maj = calloc(cells, sizeof *g->maj);
    if (!g->maj)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the majorant grid");
    if (!(density_scale > 0.0))
        return VDBS_OK;

    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    const int bmin[3] = {(int)g->lo[0], (int)g->lo[1], (int)g->lo[2]};
    for (size_t n = 0; n < volume->coord_count; ++n) {
        const int32_t *c = volume->coords + 3 * n;
        float v = vs_density_voxel(buf, &acc, vs_coord(c[0], c[1], c[2]));
        if (!(v > 0.0f))
            continue;
        /* Voxel c shapes the interpolant on the open box (c-1, c+1): the cells holding
         * the points c-1 and c along each axis. */
        int k0[3], k1[3];
        for (int a = 0; a < 3; ++a) {
            k0[a] = (c[a] - 1 - bmin[a]) / g->block;
            k1[a] = (c[a] - bmin[a]) / g->block;
            if (k0[a] < 0)
                k0[a] = 0;
            if (k1[a] > g->dims[a] - 1)
                k1[a] = g->dims[a] - 1;
        }
        for (int z = k0[2]; z <= k1[2]; ++z)
            for (int y = k0[1]; y <= k1[1]; ++y)
                for (int x = k0[0]; x <= k1[0]; ++x) {
                    float *m = &g->maj[((size_t)z * g->dims[1] + y) * g->dims[0] + x];
                    if (v > *m)
                        *m = v;
                }
    }
    /* The float interpolant can exceed its largest corner by a few ulps. */
    for (size_t i = 0; i < cells; ++i)
        g->maj[i] = (float)(g->maj[i] * density_scale * (1.0 + 1e-5));
    return VDBS_OK;
}

void vdbs_majorant_grid_free(vdbs_majorant_grid *grid)
{
    free(grid->maj);
    memset(grid, 0, sizeof *grid);
}

int vdbs_majorant_grid_clip(const vdbs_majorant_grid *g, const double o[3], const double d[3],
                            double tmax, double *t0, double *t1, int *exit_axis)
{
    double a0 = 0.0, far_min = HUGE_VAL;
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < g->lo[a] || o[a] > g->hi[a])
                return 0;
            continue;
        }
        double ta = (g->lo[a] - o[a]) / d[a], tb = (g->hi[a] - o[a]) / d[a];
        a0 = fmax(a0, fmin(ta, tb));
        if (fmax(ta, tb) < far_min) {
            far_min = fmax(ta, tb);
            axis = a;
        }
    }
    *t0 = a0;
    *t1 = fmin(tmax, far_min);
    *exit_axis = axis;
    return *t0 < *t1;
}

/* ---- DDA over the majorant cells ---- */

void vdbs_majorant_dda_init(vdbs_majorant_dda *s, const vdbs_majorant_grid *g, const double o[3],
                            const double d[3], double t0, double t1)
{
    s->grid = g;
    s->t = t0;
    s->t_end = t1;
    for (int a = 0; a < 3; ++a) {
        double q = (o[a] + d[a] * t0 - g->lo[a]) / g->block;
        int c = (int)floor(q);
        if (c < 0)
            c = 0;
        if (c > g->dims[a] - 1)
            c = g->dims[a] - 1;
        s->cell[a] = c;
        if (d[a] > 0.0) {
            s->step[a] = 1;
            s->delta[a] = g->block / d[a];
            s->next[a] = (g->lo[a] + (double)(c + 1) * g->block - o[a]) / d[a];
        } else if (d[a] < 0.0) {
            s->step[a] = -1;
            s->delta[a] = -g->block / d[a];
            s->next[a] = (g->lo[a] + (double)c * g->block - o[a]) / d[a];
        } else {
            s->step[a] = 0;
            s->delta[a] = HUGE_VAL;
            s->next[a] = HUGE_VAL;
        }
    }
}

int vdbs_majorant_dda_next(vdbs_majorant_dda *s, double *ta, double *tb, double *maj)
{
    const vdbs_majorant_grid *g = s->grid;
    if (!(s->t < s->t_end))
        return 0;
    for (int a = 0; a < 3; ++a)
        if (s->cell[a] < 0 || s->cell[a] >= g->dims[a])
            return 0;
    int a = 0;
    if (s->next[1] < s->next[a])
        a = 1;
    if (s->next[2] < s->next[a])
        a = 2;
    double te = fmin(fmax(s->next[a], s->t), s->t_end);
    *ta = s->t;
    *tb = te;
    *maj = g->maj[((size_t)s->cell[2] * g->dims[1] + s->cell[1]) * g->dims[0] + s->cell[0]];
    s->t = te;
    s->cell[a] += s->step[a];
    s->next[a] += s->delta[a];
    return 1;
}

void vdbs_medium_pack(const vdbs_medium *medium, float table[4 * VDBS_MEDIUM_TABLE_ENTRIES])
{
    const vdbs_volume *volume = medium->volume;
    memset(table, 0, sizeof(float) * 4 * VDBS_MEDIUM_TABLE_ENTRIES);
    vdbs_table_put(table + 4 * VS_MEDIUM_OFF_PARAMS, medium->density_scale, medium->g, 0.0, 0.0);
    vdbs_table_put(table + 4 * VS_MEDIUM_OFF_ALBEDO, medium->albedo[0], medium->albedo[1],
                   medium->albedo[2], 0.0);
    for (int r = 0; r < 3; ++r) {
        const double *m = volume->index_to_world[r];
        const double *inv = volume->world_to_index[r];
        vdbs_table_put(table + 4 * (VS_MEDIUM_OFF_TO_WORLD + r), m[0], m[1], m[2], 0.0);
        vdbs_table_put(table + 4 * (VS_MEDIUM_OFF_TO_INDEX + r), inv[0], inv[1], inv[2], 0.0);
    }
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    vdbs_table_put(table + 4 * VS_MEDIUM_OFF_BOX_LO, lo[0], lo[1], lo[2], 0.0);
    vdbs_table_put(table + 4 * VS_MEDIUM_OFF_BOX_HI, hi[0], hi[1], hi[2], 0.0);
}

/* ---- box-filtered density ---- */

vdbs_status vdbs_medium_box_build(const vdbs_volume *volume, int block, vdbs_medium_box *box,
                                  vdbs_error *err)
{
    memset(box, 0, sizeof *box);
    if (block < 1)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "medium box filter: block %d < 1", block);
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    for (int a = 0; a < 3; ++a) {
        box->lo[a] = (int)floorf(lo[a]);
        box->dims[a] = ((int)ceilf(hi[a]) - box->lo[a] + block - 1) / block;
        if (box->dims[a] < 1)
            box->dims[a] = 1;
    }
    box->block = block;
    size_t cells = (size_t)box->dims[0] * box->dims[1] * box->dims[2];
    box->density = calloc(cells, sizeof *box->density);
    if (!box->density)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the box-filtered medium");
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    const float inv = 1.0f / ((float)block * block * block);
    for (size_t n = 0; n < volume->coord_count; ++n) {
        const int32_t *c = volume->coords + 3 * n;
        float v = vs_density_voxel(buf, &acc, vs_coord(c[0], c[1], c[2]));
        if (!(v > 0.0f))
            continue;
        int k[3];
        int inside = 1;
        for (int a = 0; a < 3; ++a) {
            k[a] = (c[a] - box->lo[a]) / block;
            inside &= c[a] >= box->lo[a] && k[a] < box->dims[a];
        }
        if (inside)
            box->density[((size_t)k[2] * box->dims[1] + k[1]) * box->dims[0] + k[0]] += v * inv;
    }
    return VDBS_OK;
}

void vdbs_medium_box_free(vdbs_medium_box *box)
{
    free(box->density);
    memset(box, 0, sizeof *box);
}

double vdbs_medium_box_density(const vdbs_medium_box *box, const double index[3])
{
    int i0[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        double x = (index[a] - box->lo[a] + 0.5) / box->block - 0.5;
        double fl = floor(x);
        i0[a] = (int)fl;
        f[a] = x - fl;
    }
    double sum = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
        double w = 1.0;
        int c[3];
        for (int a = 0; a < 3; ++a) {
            int bit = (corner >> a) & 1;
            c[a] = i0[a] + bit;
            w *= bit ? f[a] : 1.0 - f[a];
        }
        if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[0] >= box->dims[0] || c[1] >= box->dims[1] ||
            c[2] >= box->dims[2] || w == 0.0)
            continue;
        sum += w * box->density[((size_t)c[2] * box->dims[1] + c[1]) * box->dims[0] + c[0]];
    }
    return sum;
}

double vdbs_medium_mean_density(const vdbs_volume *volume)
{
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    double sum = 0.0;
    size_t count = 0;
    for (size_t n = 0; n < volume->coord_count; ++n) {
        const int32_t *c = volume->coords + 3 * n;
        double density = vs_density_voxel(buf, &acc, vs_coord(c[0], c[1], c[2]));
        if (density > 0.0) {
            sum += density;
            ++count;
        }
    }
    return count ? sum / (double)count : 0.0;
}
