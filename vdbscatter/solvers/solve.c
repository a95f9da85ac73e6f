#include "vdbscatter/solve.h"

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
