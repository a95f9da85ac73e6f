#include "vdbscatter/solve.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The solver's own per-light callback, after the copy into solve->light_depths. */
typedef struct keep_depths {
    const vdbs_solve *solve;
    vdbs_s1_light_fn next;
    void *next_user;
} keep_depths;

/* The solver's own per-light callback, after the stored depths were kept (keep_grid). */
static void pass_depth(void *user, int light, const float *depth)
{
    const keep_depths *k = user;
    if (k->next)
        k->next(k->next_user, light, depth);
}

static vdbs_status keep_grid(void *user, int light, const vdbs_light_grids *grid, vdbs_error *err)
{
    const keep_depths *k = user;
    return vdbs_light_grids_samples(grid, 0, &k->solve->light_depths[light], err);
}

vdbs_status vdbs_solve_s1(const vdbs_solve *s, vdbs_s1_light_fn light_depth, void *light_user,
                          vdbs_error *err)
{
    keep_depths keep = {s, light_depth, light_user};
    if (s->light_depths) {
        light_depth = pass_depth;
        light_user = &keep;
    }
    vdbs_s1_outputs out = {s->radiance, s->radiance_view, light_depth, light_user,
                           s->light_depths ? keep_grid : NULL};
    vdbs_status st;
    if (s->s1_grids) {
        st = vdbs_single_scatter_grids_out(s->runner, s->volume, s->scene, s->lights, s->s1_grids,
                                           &out, s->s1_stats, s->progress, err);
        return st;
    }
    st = vdbs_single_scatter(s->runner, s->volume, s->scene, s->lights, s->radiance, s->progress,
                             err);
    if (st != VDBS_OK || (!s->radiance_view && !light_depth))
        return st;
    /* The march has no per-light output: S1 toward the camera and the lights' depths
     * come from light grids at their default oversampling (a second S1 pass; docs/lit-vdb.md
     * "radiance_view"). */
    vdbs_light_grid_desc grids = {0};
    out.radiance = NULL;
    return vdbs_single_scatter_grids_out(s->runner, s->volume, s->scene, s->lights, &grids, &out,
                                         NULL, NULL, err);
}

vdbs_status vdbs_solve_state_vec3(const vdbio_lit *lit, const char *grid, const vdbs_volume *volume,
                                  float *out, vdbs_error *err)
{
    if (!vdbio_lit_has_grid(lit, grid))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--warm-start: no grid '%s'", grid);
    vdbio_transform file;
    vdbs_status st = vdbio_lit_transform(lit, grid, &file, err);
    if (st != VDBS_OK)
        return st;
    /* The same map (the same sequence frame, or one whose grid stayed put): by index, exact. */
    const int same = memcmp(file.m, volume->index_to_world, sizeof file.m) == 0;
    double to_file[3][4];
    if (!same && !vdbs_affine_invert(file.m, to_file))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--warm-start: grid '%s' has a singular transform", grid);
    if (same)
        return vdbio_lit_vec3_many(lit, grid, volume->coords, volume->coord_count, out, err);
    int *ijk = malloc(sizeof *ijk * 3 * (volume->coord_count ? volume->coord_count : 1));
    if (!ijk)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the warm start");
    for (size_t n = 0; n < volume->coord_count; ++n) {
        double w[3];
        int inside = 1;
        vdbs_volume_voxel_point(volume, n, w);
        for (int r = 0; r < 3; ++r) {
            const double x =
                to_file[r][0] * w[0] + to_file[r][1] * w[1] + to_file[r][2] * w[2] + to_file[r][3];
            /* Beyond int's range the file has no voxel to find: one far off reads 0. */
            inside = inside && fabs(x) < 1e9;
            ijk[3 * n + r] = inside ? (int)floor(x + 0.5) : 1000000000;
        }
    }
    st = vdbio_lit_vec3_many(lit, grid, ijk, volume->coord_count, out, err);
    free(ijk);
    return st;
}
