#include "vdbscatter/solver.h"

#include <string.h>

#include "vdbscatter/single.h"

static const vdbs_quality qualities[] = {
    {"low", 16, 1.0f},
    {"medium", 64, 0.5f},
    {"high", 256, 0.25f},
    {"ultra", 1024, 0.125f},
};

const vdbs_quality *vdbs_quality_find(const char *name)
{
    for (size_t q = 0; name && q < sizeof qualities / sizeof qualities[0]; ++q)
        if (strcmp(name, qualities[q].name) == 0)
            return &qualities[q];
    return NULL;
}

int vdbs_quality_sky_directions(const char *name)
{
    const vdbs_quality *q = vdbs_quality_find(name);
    return q ? q->sky_directions : 0;
}

/* Single scattering only: S1 into radiance; ms and its moments stay 0. */
static vdbs_status run_single(const vdbs_solve *s, vdbs_error *err)
{
    if (s->s1_grids)
        return vdbs_single_scatter_grids(s->runner, s->volume, s->scene, s->lights, s->s1_grids,
                                         s->radiance, s->s1_stats, s->progress, err);
    return vdbs_single_scatter(s->runner, s->volume, s->scene, s->lights, s->radiance, s->progress,
                               err);
}

static const vdbs_solver solvers[VDBS_METHOD_COUNT] = {
    {VDBS_METHOD_SINGLE, "single", "exact single scattering only (no multiple scattering)", 0,
     run_single},
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
