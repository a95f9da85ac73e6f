#include "vdbscatter/inet_live.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/lights.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/phasemat.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/solver.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_march.h"

/* The bake's cap of sweeps when the scene sets none (inet.c). */
#define LIVE_MAX_ITERATIONS 1000

struct vdbs_inet_live {
    const vdbs_volume *volume;
    vdbs_scene *scene; /* the medium and solver options; the current lights */
    vdbs_runner *runner;
    int own_runner;
    double residual;
    int max_iterations;
    vdbs_inet_setup setup; /* the phase, the network and its slots */
    /* E per particle and direction (N D x 3): the direct lights', the sky ordinates', and
     * their sum that the sweeps read. Kept apart so that a moved sun re-marches only the
     * direct lights. */
    float *e_direct, *e_sky, *emission;
    double first; /* the sum of emission; the reference of a sweep's change */
    vdbs_light_table lights;
    int have_lights;
    float medium[4 * VDBS_MEDIUM_TABLE_ENTRIES];
    float *state;    /* links then sinks, 3 floats a slot */
    double *scratch; /* N: the line sweep's per-chain changes */
    /* N x D: downstream[p D + d], the particle whose upstream along d is p, or -1: the
     * chains walked from their heads by the line sweep */
    int32_t *downstream;
    vdbs_inet_live_status status;
    vdbs_inet_live_opening opening;
};

/* An inet option's value at the quality (solver.h): the scene's, else the bake's preset. */
static double inet_option(const vdbs_scene *scene, const char *key, const vdbs_quality *quality)
{
    const vdbs_solver *solver = vdbs_solver_find("inet");
    for (int i = 0; solver && i < solver->option_count; ++i)
        if (strcmp(solver->options[i].key, key) == 0)
            return vdbs_solver_option_value(scene, &solver->options[i], quality);
    return 0.0;
}

/* The unscattered light that lights [first, first + count) of the table bring to the
 * particles, scattered once into out (N D x 3, zeroed here). Per particle the transmittance
 * is marched from its point to each light (vs_march.h, in index space), times the light's
 * arrival there. Particles fall in the voxels in proportion to the voxel cube's optical mass
 * and are placed uniformly inside, so E T at a particle's point is an unbiased estimate of the
 * voxel's cube average of E T, which is the bake's collided irradiance (rate over the cube's
 * mean sigma_t, collision.h) where sigma_t is constant over the voxel; only the trilinear
 * density's variation inside a voxel separates the two. */
static void seed_lights(vdbs_inet_live *l, int first, int count, float *out)
{
    const vdbs_inet_network *net = &l->setup.net;
    const vdbs_volume *volume = l->volume;
    const vdbs_light_table *table = &l->lights;
    memset(out, 0, sizeof *out * 3 * (size_t)l->setup.links.links);
    if (count <= 0)
        return;
    const vs_vec4 *medium = (const vs_vec4 *)l->medium;
    const vs_vec4 *lights = (const vs_vec4 *)table->packed;
    const pnanovdb_vec3_t box_lo = vs_medium_box_lo(medium);
    const pnanovdb_vec3_t box_hi = vs_medium_box_hi(medium);
    const float density_scale = vs_medium_density_scale(medium);
    const int direct = table->direct_count;
    const double g = l->scene->g;
#pragma omp parallel for schedule(dynamic, 64)
    for (int64_t p = 0; p < net->particles; ++p) {
        pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
        pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
        double world[3], index[3];
        for (int a = 0; a < 3; ++a)
            world[a] = net->position[3 * p + a];
        vdbs_volume_index_point(volume, world, index);
        const pnanovdb_vec3_t at = vs_vec3((float)index[0], (float)index[1], (float)index[2]);
        for (int i = first; i < first + count; ++i) {
            float t;
            if (i >= direct) {
                t = vs_transmittance(buf, &acc, at, vs_ordinate_index(lights, i - direct),
                                     VS_T_INFINITE, box_lo, box_hi, density_scale);
            } else if (vs_light_type(lights, i) == VS_LIGHT_SUN) {
                t = vs_transmittance(buf, &acc, at, vs_light_index(lights, i), VS_T_INFINITE,
                                     box_lo, box_hi, density_scale);
            } else {
                vs_point_view v = vs_point_light_view(medium, lights, i, at);
                const float r = v.distance;
                t = r > 0.0f ? vs_transmittance(buf, &acc, at, vs_vec3_scale(v.offset, 1.0f / r), r,
                                                box_lo, box_hi, density_scale)
                             : 1.0f;
            }
            if (!(t > 0.0f))
                continue;
            double color[3], travel[3], irradiance[3];
            vdbs_lights_arrival(table, i, world, color, travel);
            for (int ch = 0; ch < 3; ++ch)
                irradiance[ch] = color[ch] * (double)t;
            vdbs_inet_emit(net, g, l->scene->albedo, p, irradiance, travel, out);
        }
    }
}

/* emission = e_direct + e_sky, and its total. */
static void sum_emission(vdbs_inet_live *l)
{
    const int64_t count = 3 * l->setup.links.links;
    double first = 0.0;
    for (int64_t k = 0; k < count; ++k) {
        l->emission[k] = l->e_direct[k] + l->e_sky[k];
        first += l->emission[k];
    }
    l->first = first;
}

/* Whether two tables' sky ordinates light alike. */
static int same_sky(const vdbs_light_table *a, const vdbs_light_table *b)
{
    if (a->ordinate_count != b->ordinate_count)
        return 0;
    for (int k = 0; k < a->ordinate_count; ++k) {
        const vdbs_sky_ordinate *p = &a->ordinates[k], *q = &b->ordinates[k];
        if (p->weight != q->weight)
            return 0;
        for (int c = 0; c < 3; ++c)
            if (p->world[c] != q->world[c] || p->radiance[c] != q->radiance[c])
                return 0;
    }
    return 1;
}

/* Resolves the scene's lights and seeds E: the direct lights always, the sky unless its
 * ordinates are those already seeded (`keep_sky`). */
static vdbs_status seed(vdbs_inet_live *l, const vdbs_scene *scene, int keep_sky, vdbs_error *err)
{
    const vdbs_solver *inet = vdbs_solver_find("inet");
    const vdbs_quality *quality = vdbs_solver_quality(inet, vdbs_quality_find(l->scene->quality));
    vdbs_lights_desc ld = {0};
    ld.sky_ordinates = vdbs_solver_sky_directions(inet, scene, quality);
    vdbs_light_table table;
    vdbs_status st = vdbs_lights_build(l->volume, scene, &ld, &table, err);
    if (st != VDBS_OK)
        return st;
    keep_sky = keep_sky && l->have_lights && same_sky(&l->lights, &table);
    if (l->have_lights)
        vdbs_lights_free(&l->lights);
    l->lights = table;
    l->have_lights = 1;
    seed_lights(l, 0, table.direct_count, l->e_direct);
    if (!keep_sky)
        seed_lights(l, table.direct_count, table.ordinate_count, l->e_sky);
    sum_emission(l);
    memset(&l->status, 0, sizeof l->status);
    l->status.tolerance = l->residual;
    return VDBS_OK;
}

/* The problem the sweeps solve: the network, its phase, the current first scattering. */
static vdbs_inet_problem live_problem(const vdbs_inet_live *l)
{
    vdbs_inet_problem pb = {.net = &l->setup.net,
                            .links = &l->setup.links,
                            .phase = l->setup.phase,
                            .opacity = vdbs_inet_opacity(&l->setup.net),
                            .emission = l->emission};
    for (int ch = 0; ch < 3; ++ch)
        pb.albedo[ch] = l->scene->albedo[ch];
    return pb;
}

/* The cold solve: up to `sweeps` Jacobi sweeps from the state through the runner, stopping at
 * the estimated residual, as the bake's (vdbs_inet_solve): the same converged state as the
 * baked ms. */
static vdbs_status run_sweeps(vdbs_inet_live *l, int sweeps, vdbs_progress *progress,
                              vdbs_error *err)
{
    const vdbs_inet_problem pb = live_problem(l);
    /* Without light the state decays to 0: its change is measured against nothing, so the
     * tolerance is absolute there. */
    const double reference = l->first > 0.0 ? l->first : 1.0;
    vdbs_inet_solve_result sr = {0};
    vdbs_status st = vdbs_inet_solve(l->runner, &pb, sweeps, l->residual, reference, l->state,
                                     progress, &sr, err);
    if (st != VDBS_OK)
        return st;
    l->status.sweeps += sr.iterations;
    l->status.change = sr.change;
    l->status.converged = sr.converged;
    return VDBS_OK;
}

void vdbs_inet_live_destroy(vdbs_inet_live *l)
{
    if (!l)
        return;
    vdbs_inet_setup_free(&l->setup);
    free(l->e_direct);
    free(l->e_sky);
    free(l->emission);
    if (l->have_lights)
        vdbs_lights_free(&l->lights);
    free(l->state);
    free(l->scratch);
    free(l->downstream);
    free(l->scene);
    if (l->own_runner)
        vdbs_runner_destroy(l->runner);
    free(l);
}

/* The network, its links and the phase matrix of the bake's for the quality. */
static vdbs_status build_network(vdbs_inet_live *l, const vdbs_quality *quality, vdbs_error *err)
{
    const vdbs_scene *scene = l->scene;
    const int64_t particles = (int64_t)inet_option(scene, "inet_particles", quality);
    const int directions = (int)inet_option(scene, "inet_directions", quality);
    /* Seed 0, as the bake's: the same particles and network. */
    vdbs_status st =
        vdbs_inet_setup_build(l->volume, scene->density_scale, scene->g, particles, directions,
                              (int)inet_option(scene, "inet_window", quality), 0, &l->setup, err);
    if (st != VDBS_OK)
        return st;
    const size_t links = 3 * (size_t)l->setup.links.links;
    const size_t slots = 3 * (size_t)(l->setup.links.links + l->setup.links.sinks);
    l->e_direct = calloc(links, sizeof *l->e_direct);
    l->e_sky = calloc(links, sizeof *l->e_sky);
    l->emission = calloc(links, sizeof *l->emission);
    l->state = calloc(slots, sizeof *l->state);
    l->scratch = malloc(sizeof *l->scratch *
                        (size_t)(l->setup.net.particles > 0 ? l->setup.net.particles : 1));
    l->downstream = malloc(sizeof *l->downstream * (links / 3 ? links / 3 : 1));
    if (!l->e_direct || !l->e_sky || !l->emission || !l->state || !l->scratch || !l->downstream)
        return vdbs_error_set(err, VDBS_ERR_NOMEM,
                              "out of memory for %lld particles x %d directions",
                              (long long)particles, directions);
    const int64_t count = l->setup.links.links;
    for (int64_t k = 0; k < count; ++k)
        l->downstream[k] = -1;
    for (int64_t k = 0; k < count; ++k)
        if (l->setup.net.upstream[k] >= 0)
            l->downstream[(int64_t)l->setup.net.upstream[k] * directions + k % directions] =
                (int32_t)(k / directions);
    return VDBS_OK;
}

vdbs_status vdbs_inet_live_create(const vdbs_inet_live_desc *d, vdbs_inet_live **out,
                                  vdbs_error *err)
{
    *out = NULL;
    if (!d->volume || !d->scene)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "inet live: no volume or scene");
    vdbs_inet_live *l = calloc(1, sizeof *l);
    if (!l || !(l->scene = malloc(sizeof *l->scene))) {
        free(l);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    }
    l->volume = d->volume;
    *l->scene = *d->scene;
    vdbs_scene_copy_lights(l->scene, d->scene); /* the env paths point into the copy */
    const char *name = d->quality && d->quality[0]    ? d->quality
                       : l->scene->quality[0] != '\0' ? l->scene->quality
                                                      : "medium";
    const vdbs_quality *quality =
        vdbs_solver_quality(vdbs_solver_find("inet"), vdbs_quality_find(name));
    vdbs_status st = VDBS_OK;
    if (!quality)
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "inet live: unknown quality '%s'", name);
    else
        snprintf(l->scene->quality, sizeof l->scene->quality, "%s", quality->name);
    if (st == VDBS_OK) {
        l->residual = inet_option(l->scene, "inet_residual", quality);
        l->max_iterations = (int)inet_option(l->scene, "inet_iterations", quality);
        if (l->max_iterations <= 0)
            l->max_iterations = LIVE_MAX_ITERATIONS;
        l->runner = d->runner;
        if (!l->runner) {
            vdbs_runner_desc rd = {.backend = VDBS_BACKEND_CPU};
            st = vdbs_runner_create(&rd, &l->runner, err);
            l->own_runner = st == VDBS_OK;
        }
    }
    if (st == VDBS_OK) {
        vdbs_medium medium;
        vdbs_medium_init(&medium, l->volume, l->scene);
        vdbs_medium_pack(&medium, l->medium);
        st = build_network(l, quality, err);
    }
    if (st == VDBS_OK)
        st = seed(l, d->scene, 0, err);
    /* From a kept state of the same D: its voxels' radiance, then warm line sweeps. */
    const int directions = l->setup.net.directions;
    if (st == VDBS_OK && d->state && vdbs_inet_voxel_state_directions(d->state) == directions) {
        vdbs_inet_voxel_state vs;
        st = vdbs_inet_voxel_state_read(d->state, d->state_path ? d->state_path : "the lit VDB",
                                        l->volume, directions, &vs, err);
        if (st == VDBS_OK) {
            vdbs_inet_voxel_state_start(&l->setup.net, &vs, l->state);
            vdbs_inet_voxel_state_free(&vs);
            l->opening.from_state = 1;
            st = vdbs_inet_live_sweep(l, l->max_iterations, NULL, err);
            l->opening.sweeps = l->status.sweeps;
        }
    } else if (st == VDBS_OK && l->first > 0.0) {
        if (d->progress)
            vdbs_progress_begin(d->progress, d->progress->enabled, "inet sweeps",
                                (uint64_t)l->max_iterations);
        st = run_sweeps(l, l->max_iterations, d->progress, err);
        l->opening.sweeps = l->status.sweeps;
    } else if (st == VDBS_OK) {
        l->status.converged = 1;
    }
    if (st != VDBS_OK) {
        vdbs_inet_live_destroy(l);
        return st;
    }
    *out = l;
    return VDBS_OK;
}

vdbs_status vdbs_inet_live_set_lights(vdbs_inet_live *l, const vdbs_scene *scene, vdbs_error *err)
{
    vdbs_status st = seed(l, scene, 1, err);
    if (st == VDBS_OK)
        vdbs_scene_copy_lights(l->scene, scene);
    return st;
}

vdbs_status vdbs_inet_live_sweep(vdbs_inet_live *l, int sweeps, vdbs_inet_live_status *status,
                                 vdbs_error *err)
{
    vdbs_status st = VDBS_OK;
    (void)err; /* the line sweep is the C path's and allocates nothing */
    const double reference = l->first > 0.0 ? l->first : 1.0;
    const vdbs_inet_problem pb = live_problem(l);
    for (int k = 0; k < sweeps && !(l->status.sweeps > 0 && l->status.converged); ++k) {
        l->status.change =
            vdbs_inet_line_sweep(&pb, l->downstream, l->state, l->scratch) / reference;
        l->status.sweeps += 1;
        l->status.converged = l->status.change <= l->residual;
    }
    if (status)
        *status = l->status;
    return st;
}

vdbs_status vdbs_inet_live_ms(const vdbs_inet_live *l, float *ms, float *const ms_l1[3],
                              vdbs_error *err)
{
    const size_t n = 3 * l->volume->coord_count;
    memset(ms, 0, sizeof *ms * n);
    for (int a = 0; a < 3; ++a)
        memset(ms_l1[a], 0, sizeof *ms_l1[a] * n);
    const vdbs_inet_problem pb = live_problem(l);
    return vdbs_inet_to_voxels(&pb, l->state, l->volume, l->scene->density_scale, l->scene->g, ms,
                               ms_l1, NULL, NULL, err);
}

vdbs_inet_problem vdbs_inet_live_problem(const vdbs_inet_live *l)
{
    return live_problem(l);
}

const float *vdbs_inet_live_state(const vdbs_inet_live *l)
{
    return l->state;
}

vdbs_inet_live_opening vdbs_inet_live_opened(const vdbs_inet_live *l)
{
    return l->opening;
}
