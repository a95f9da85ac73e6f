#include "vdbscatter/solve.h"

vdbs_status vdbs_solve_s1(const vdbs_solve *s, float *flux, vdbs_s1_light_fn light_depth,
                          void *light_user, vdbs_error *err)
{
    vdbs_s1_outputs out = {s->radiance, s->radiance_view, flux, light_depth, light_user};
    if (s->s1_grids)
        return vdbs_single_scatter_grids_out(s->runner, s->volume, s->scene, s->lights, s->s1_grids,
                                             &out, s->s1_stats, s->progress, err);
    vdbs_status st = vdbs_single_scatter(s->runner, s->volume, s->scene, s->lights, s->radiance,
                                         s->progress, err);
    if (st != VDBS_OK || (!s->radiance_view && !flux && !light_depth))
        return st;
    /* The march has no per-light output: S1 toward the camera, the flux and the lights' depths
     * come from light grids at their default oversampling (a second S1 pass; docs/lit-vdb.md
     * "radiance_view"). */
    vdbs_light_grid_desc grids = {0};
    out.radiance = NULL;
    return vdbs_single_scatter_grids_out(s->runner, s->volume, s->scene, s->lights, &grids, &out,
                                         NULL, NULL, err);
}
