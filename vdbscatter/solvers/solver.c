#include "vdbscatter/solver.h"

#include <stdlib.h>
#include <string.h>

#include "vdbscatter/fld.h"
#include "vdbscatter/pop.h"
#include "vdbscatter/single.h"
#include "vdbscatter/svd.h"

/* S1 into radiance (and toward the camera), with flux the unscattered light's net flux and
 * with light_depth every light's optical depth (vdbs_s1_outputs). */
static vdbs_status run_s1(const vdbs_solve *s, float *flux, vdbs_s1_light_fn light_depth,
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

/* Single scattering only; ms and its moments stay 0. */
static vdbs_status run_single(const vdbs_solve *s, vdbs_error *err)
{
    return run_s1(s, NULL, NULL, NULL, err);
}

/* Exact S1, then POP's multiple scattering from suns and skies. */
static vdbs_status run_pop(const vdbs_solve *s, vdbs_error *err)
{
    vdbs_status st = run_single(s, err);
    if (st != VDBS_OK)
        return st;
    vdbs_pop_desc desc = {0};
    desc.resolution = s->scene->pop_resolution;
    desc.ordinates = s->scene->pop_ordinates;
    desc.max_iterations = s->scene->pop_iterations;
    desc.decay = s->scene->pop_decay_paper ? VDBS_POP_DECAY_PAPER : VDBS_POP_DECAY_MEAN_COSINE;
    desc.tally_cell = s->scene->pop_tally_cell;
    desc.radial = s->scene->pop_radial;
    desc.importance = s->scene->pop_importance;
    vdbs_pop_stats stats;
    st = vdbs_pop_solve(s, &desc, &stats, err);
    if (s->pop_stats)
        *s->pop_stats = stats;
    return st;
}

/* Exact S1 (with the unscattered light's flux for the first-moment source unless g = 0 or
 * --fld-p1 off), then flux-limited diffusion of the first-scattered light. */
static vdbs_status run_fld(const vdbs_solve *s, vdbs_error *err)
{
    float *flux = NULL;
    if (s->scene->g != 0.0 && !s->scene->fld_p1_off && s->volume->coord_count > 0) {
        flux = malloc(sizeof *flux * 9 * s->volume->coord_count);
        if (!flux)
            return vdbs_error_set(err, VDBS_ERR_NOMEM,
                                  "out of memory for the S1 flux of %zu voxels",
                                  s->volume->coord_count);
    }
    vdbs_status st = run_s1(s, flux, NULL, NULL, err);
    if (st == VDBS_OK) {
        vdbs_fld_desc desc = {0};
        desc.resolution = s->scene->fld_resolution;
        desc.limiter_off = s->scene->fld_limiter_off;
        desc.write_l1 = !s->scene->fld_l1_off;
        desc.s1_flux = flux;
        vdbs_fld_stats stats;
        st = vdbs_fld_solve(s, &desc, &stats, err);
        if (s->fld_stats)
            *s->fld_stats = stats;
    }
    free(flux);
    return st;
}

/* Exact S1, then discrete ordinates with the factored phase on the first-scattered light,
 * which comes from the S1 pass's own light grids. */
static vdbs_status run_svd(const vdbs_solve *s, vdbs_error *err)
{
    vdbs_svd_desc desc = {0};
    desc.directions = s->scene->svd_directions;
    desc.terms = s->scene->svd_terms;
    desc.resolution = s->scene->svd_resolution;
    desc.residual = s->scene->svd_residual;
    desc.max_iterations = s->scene->svd_iterations;
    desc.warm = s->svd_warm;
    desc.keep = s->svd_keep;
    desc.progress = s->progress;
    vdbs_svd_run *run = NULL;
    vdbs_status st = vdbs_svd_begin(s, &desc, &run, err);
    if (st == VDBS_OK)
        st = run_s1(s, NULL, vdbs_svd_light_depth, run, err);
    if (st == VDBS_OK)
        st = vdbs_svd_finish(run, s->svd_stats, err);
    vdbs_svd_end(run);
    return st;
}

static const vdbs_solver solvers[VDBS_METHOD_COUNT] = {
    {VDBS_METHOD_SINGLE, "single", "exact single scattering only (no multiple scattering)", 0,
     run_single},
    {VDBS_METHOD_POP, "pop",
     "exact single scattering + Principal-Ordinates Propagation (suns, skies, points)", 1, run_pop},
    {VDBS_METHOD_FLD, "fld",
     "exact single scattering + flux-limited diffusion of the first-scattered light", 1, run_fld},
    {VDBS_METHOD_SVD, "svd",
     "exact single scattering + discrete ordinates with the SVD-factored phase (Gong et al.)", 1,
     run_svd},
};

const vdbs_solver *vdbs_solver_find(const char *name)
{
    for (int m = 0; name && m < VDBS_METHOD_COUNT; ++m)
        if (strcmp(name, solvers[m].name) == 0)
            return &solvers[m];
    return NULL;
}

const vdbs_solver *vdbs_solver_list(int *count)
{
    *count = VDBS_METHOD_COUNT;
    return solvers;
}

void vdbs_solver_names(char *buf, size_t size)
{
    if (size == 0)
        return;
    buf[0] = '\0';
    for (int m = 0; m < VDBS_METHOD_COUNT; ++m) {
        if (m > 0)
            strncat(buf, ", ", size - strlen(buf) - 1);
        strncat(buf, solvers[m].name, size - strlen(buf) - 1);
    }
}
