#include "vdbscatter/litvdb.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const ms_grid_names[4] = {"ms", "ms_l1x", "ms_l1y", "ms_l1z"};

int vdbs_lit_grids_have_ms(const vdbs_lit_grids *ms)
{
    return ms && ms->ms && ms->l1x && ms->l1y && ms->l1z;
}

void vdbs_lit_grids_free(vdbs_lit_grids *grids)
{
    if (!grids)
        return;
    free(grids->ms);
    free(grids->l1x);
    free(grids->l1y);
    free(grids->l1z);
    for (int i = 0; grids->depth && i < grids->depth_count; ++i) {
        free(grids->depth[i].grid);
        free(grids->depth[i].radii);
    }
    free(grids->depth);
    memset(grids, 0, sizeof *grids);
}

void vdbs_lit_depth_name(int light, int direct, char *name, size_t size)
{
    if (light < direct)
        snprintf(name, size, "light_depth_%03d", light);
    else
        snprintf(name, size, "sky_depth_%04d", light - direct);
}

static int same_transform(const vdbio_transform *a, const double b[3][4])
{
    double scale = 0.0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            scale = fmax(scale, fabs(b[r][c]));
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            if (!(fabs(a->m[r][c] - b[r][c]) <= 1e-9 * scale))
                return 0;
    return 1;
}

/* to_grid = inverse(grid) * density, 3x4 affine maps (column vectors). Returns 0 when the
 * grid's map is singular. */
static int density_to_grid(const double grid[3][4], const double density[3][4],
                           double to_grid[3][4])
{
    double inv[3][3];
    double det = grid[0][0] * (grid[1][1] * grid[2][2] - grid[1][2] * grid[2][1]) -
                 grid[0][1] * (grid[1][0] * grid[2][2] - grid[1][2] * grid[2][0]) +
                 grid[0][2] * (grid[1][0] * grid[2][1] - grid[1][1] * grid[2][0]);
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            inv[r][c] = (grid[r1][c1] * grid[r2][c2] - grid[r1][c2] * grid[r2][c1]) / det;
        }
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
            double v = 0.0;
            for (int q = 0; q < 3; ++q)
                v += inv[r][q] * (density[q][c] - (c == 3 ? grid[q][3] : 0.0));
            to_grid[r][c] = v;
        }
    return 1;
}

/* One grid of the file as a NanoVDB buffer; with to_grid NULL checked to lie on the density's
 * transform, else the map to its own index space goes there. */
static vdbs_status load_grid(const vdbio_lit *lit, const char *name, int is_vec3,
                             const double index_to_world[3][4], uint32_t **buffer, size_t *size,
                             double (*to_grid)[4], vdbs_error *err)
{
    vdbio_transform t;
    vdbs_status st = vdbio_lit_transform(lit, name, &t, err);
    if (st == VDBS_OK && to_grid && !density_to_grid(t.m, index_to_world, to_grid))
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "grid '%s' has a singular transform", name);
    if (st == VDBS_OK && !to_grid && !same_transform(&t, index_to_world))
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "grid '%s' is not on the density grid's transform",
                            name);
    void *b = NULL;
    if (st == VDBS_OK)
        st = is_vec3 ? vdbio_lit_vec3_nanovdb(lit, name, &b, size, err)
                     : vdbio_lit_float_nanovdb(lit, name, &b, size, err);
    *buffer = b;
    return st;
}

/* The point lights' grid layouts from vdbscatter_lights (docs/lit-vdb.md). */
static vdbs_status load_layouts(const vdbio_lit *lit, vdbs_lit_grids *out, vdbs_error *err)
{
    const char *text = vdbio_lit_meta(lit, "vdbscatter_lights");
    cJSON *list = text ? cJSON_Parse(text) : NULL;
    vdbs_status st = VDBS_OK;
    if (!cJSON_IsArray(list) || cJSON_GetArraySize(list) != out->depth_count)
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "vdbscatter_lights metadata missing or not one entry per depth grid");
    for (int i = 0; st == VDBS_OK && i < out->depth_count; ++i) {
        const cJSON *e = cJSON_GetArrayItem(list, i);
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(e, "type");
        if (!cJSON_IsString(type) || strcmp(type->valuestring, "point") != 0)
            continue;
        vdbs_lit_depth *d = &out->depth[i];
        const cJSON *texels = cJSON_GetObjectItemCaseSensitive(e, "texels");
        const cJSON *radii = cJSON_GetObjectItemCaseSensitive(e, "radii");
        int shells = cJSON_IsArray(radii) ? cJSON_GetArraySize(radii) : 0;
        if (!cJSON_IsNumber(texels) || texels->valuedouble < 1 || shells < 2) {
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "vdbscatter_lights: point light %d has no texels and radii", i);
            break;
        }
        d->radial = 1;
        d->texels = (int)texels->valuedouble;
        d->shells = shells;
        if (!(d->radii = malloc(sizeof *d->radii * (size_t)shells))) {
            st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for shell radii");
            break;
        }
        for (int k = 0; k < shells; ++k) {
            const cJSON *r = cJSON_GetArrayItem(radii, k);
            d->radii[k] = cJSON_IsNumber(r) ? (float)r->valuedouble : NAN;
            if (!isfinite(d->radii[k]) || (k > 0 && !(d->radii[k] > d->radii[k - 1])))
                st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                    "vdbscatter_lights: point light %d has bad shell radii", i);
        }
    }
    cJSON_Delete(list);
    return st;
}

/* The stored depths: light_depth_* then sky_depth_*, each numbered from 0 until one is
 * missing. */
static vdbs_status load_depths(const vdbio_lit *lit, const double index_to_world[3][4],
                               vdbs_lit_grids *out, vdbs_error *err)
{
    char name[32];
    int direct = 0, sky = 0;
    for (;; ++direct) {
        vdbs_lit_depth_name(direct, direct + 1, name, sizeof name);
        if (!vdbio_lit_has_grid(lit, name))
            break;
    }
    for (;; ++sky) {
        vdbs_lit_depth_name(direct + sky, direct, name, sizeof name);
        if (!vdbio_lit_has_grid(lit, name))
            break;
    }
    int n = direct + sky;
    if (n == 0)
        return VDBS_OK;
    out->depth = calloc((size_t)n, sizeof *out->depth);
    if (!out->depth)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %d depth grids", n);
    out->depth_count = n;
    out->depth_direct = direct;
    /* The grids convert side by side (a sky of 256 ordinates has as many; the file's grids are
     * only read here); the first failing grid in order is the one reported. */
    vdbs_status first = VDBS_OK;
    int first_at = n;
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < n; ++i) {
        vdbs_lit_depth *d = &out->depth[i];
        char grid_name[32];
        vdbs_error grid_err;
        vdbs_lit_depth_name(i, direct, grid_name, sizeof grid_name);
        vdbs_status st =
            load_grid(lit, grid_name, 0, index_to_world, &d->grid, &d->size, d->to_grid, &grid_err);
        if (st != VDBS_OK) {
#pragma omp critical(vdbs_lit_depth_error)
            if (i < first_at) {
                first_at = i;
                first = st;
                if (err)
                    *err = grid_err;
            }
        }
    }
    return first != VDBS_OK ? first : load_layouts(lit, out, err);
}

vdbs_status vdbs_lit_grids_load(const vdbio_lit *lit, const double index_to_world[3][4], int depths,
                                vdbs_lit_grids *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    uint32_t **bufs[4] = {&out->ms, &out->l1x, &out->l1y, &out->l1z};
    size_t *sizes[4] = {&out->ms_size, &out->l1x_size, &out->l1y_size, &out->l1z_size};
    vdbs_status st = VDBS_OK;
    for (int i = 0; i < 4 && st == VDBS_OK; ++i)
        st = load_grid(lit, ms_grid_names[i], 1, index_to_world, bufs[i], sizes[i], NULL, err);
    if (st == VDBS_OK && depths)
        st = load_depths(lit, index_to_world, out, err);
    if (st != VDBS_OK)
        vdbs_lit_grids_free(out);
    return st;
}
