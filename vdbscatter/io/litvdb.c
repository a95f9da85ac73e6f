#include "vdbscatter/litvdb.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const ms_grid_names[4] = {"ms", "ms_l1x", "ms_l1y", "ms_l1z"};

int vdbs_ms_grids_present(const vdbs_ms_grids *ms)
{
    return ms && ms->ms && ms->l1x && ms->l1y && ms->l1z;
}

void vdbs_ms_grids_free(vdbs_ms_grids *grids)
{
    if (!grids)
        return;
    free(grids->ms);
    free(grids->l1x);
    free(grids->l1y);
    free(grids->l1z);
    memset(grids, 0, sizeof *grids);
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

vdbs_status vdbs_ms_grids_load(const vdbio_lit *lit, const double index_to_world[3][4],
                               vdbs_ms_grids *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    uint32_t **bufs[4] = {&out->ms, &out->l1x, &out->l1y, &out->l1z};
    size_t *sizes[4] = {&out->ms_size, &out->l1x_size, &out->l1y_size, &out->l1z_size};
    for (int i = 0; i < 4; ++i) {
        vdbio_transform t;
        vdbs_status st = vdbio_lit_transform(lit, ms_grid_names[i], &t, err);
        if (st == VDBS_OK && !same_transform(&t, index_to_world))
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "grid '%s' is not on the density grid's transform",
                                ms_grid_names[i]);
        void *buffer = NULL;
        if (st == VDBS_OK)
            st = vdbio_lit_vec3_nanovdb(lit, ms_grid_names[i], &buffer, sizes[i], err);
        if (st != VDBS_OK) {
            vdbs_ms_grids_free(out);
            return st;
        }
        *bufs[i] = buffer;
    }
    return VDBS_OK;
}
