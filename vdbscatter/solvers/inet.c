#include "vdbscatter/inet.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"
#include "vdbscatter/coarse.h"
#include "vdbscatter/collision.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/phasemat.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_inet.h"
#include "vs_pass.h"
#include "vs_phase.h"

/* Default cap of sweeps. */
#define INET_MAX_ITERATIONS 1000

/* ---- the slots ---- */

vdbs_status vdbs_inet_links_build(const vdbs_inet_network *net, vdbs_inet_links *links,
                                  vdbs_error *err)
{
    memset(links, 0, sizeof *links);
    const int64_t n = net->particles, dirs = net->directions, count = n * dirs;
    /* A particle is a chain's end along d when no particle names it upstream for d. */
    uint8_t *named = calloc((size_t)(count > 0 ? count : 1), 1);
    if (!named)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the network's links");
    for (int64_t s = 0; s < count; ++s)
        if (net->upstream[s] >= 0)
            named[(int64_t)net->upstream[s] * dirs + s % dirs] = 1;
    int64_t sinks = 0;
    for (int64_t s = 0; s < count; ++s)
        sinks += !named[s];
    links->source = malloc(sizeof *links->source * (size_t)(count + 2 * sinks));
    if (!links->source) {
        free(named);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the network's links");
    }
    memcpy(links->source, net->upstream, sizeof *links->source * (size_t)count);
    int64_t k = 0;
    for (int64_t s = 0; s < count; ++s)
        if (!named[s]) {
            links->source[count + k] = (int32_t)(s / dirs);
            links->source[count + sinks + k] = (int32_t)(s % dirs);
            ++k;
        }
    free(named);
    links->links = count;
    links->sinks = sinks;
    return VDBS_OK;
}

void vdbs_inet_links_free(vdbs_inet_links *links)
{
    free(links->source);
    memset(links, 0, sizeof *links);
}

double vdbs_inet_opacity(const vdbs_inet_network *net)
{
    return net->pixel_area > 0.0 ? -expm1(-net->mass / net->pixel_area) : 1.0;
}

/* ---- the sweep through the runner ---- */

static void put_float(uint32_t *words, int at, double value)
{
    float f = (float)value;
    memcpy(&words[at], &f, sizeof f);
}

typedef struct inet_kernel {
    uint32_t params[VS_INET_PARAM_WORDS];
    const int32_t *source;
    const float *phase, *emission;
} inet_kernel;

/* The kernel's parameter words and tables for a problem (vs_inet.h). */
static void kernel_make(const vdbs_inet_problem *pb, inet_kernel *k)
{
    memset(k, 0, sizeof *k);
    k->source = pb->links->source;
    k->phase = pb->phase;
    k->emission = pb->emission;
    k->params[VS_INET_OFF_PARTICLES] = (uint32_t)pb->net->particles;
    k->params[VS_INET_OFF_DIRECTIONS] = (uint32_t)pb->net->directions;
    put_float(k->params, VS_INET_OFF_OPACITY, pb->opacity);
    for (int ch = 0; ch < 3; ++ch) {
        put_float(k->params, VS_INET_OFF_ALBEDO + ch, pb->albedo[ch]);
        put_float(k->params, VS_INET_OFF_INFLOW + ch, pb->inflow[ch]);
    }
    k->params[VS_INET_OFF_EMISSION] = pb->emission ? 1u : 0u;
    k->params[VS_INET_OFF_SINKS] = (uint32_t)pb->links->sinks;
}

/* One slot's new value from `in` into `out` (which may be `in`); its change, summed over the
 * channels. */
static double slot_update(const inet_kernel *k, const float *in, float *out, int s)
{
    pnanovdb_vec3_t l = vs_inet_slot(k->params, k->source, k->phase, k->emission, in, s);
    const double change = fabs((double)l.x - in[3 * s]) + fabs((double)l.y - in[3 * s + 1]) +
                          fabs((double)l.z - in[3 * s + 2]);
    out[3 * s] = l.x;
    out[3 * s + 1] = l.y;
    out[3 * s + 2] = l.z;
    return change;
}

VS_CPU_CLONES static double inet_step(void *user, int step, const void *state_in, void *state_out,
                                      uint64_t begin, uint64_t end)
{
    (void)step;
    const inet_kernel *k = user;
    const float *in = state_in;
    float *out = state_out;
    double change = 0.0;
    for (uint64_t item = begin; item < end; ++item)
        change += slot_update(k, in, out, (int)item);
    return change;
}

vdbs_status vdbs_inet_iterate(vdbs_runner *runner, const vdbs_inet_problem *pb, int max_iterations,
                              double tolerance, float *state, vdbs_progress *progress,
                              vdbs_kernel_result *result, vdbs_error *err)
{
    const vdbs_inet_network *net = pb->net;
    const int64_t slots = pb->links->links + pb->links->sinks;
    if (slots > INT32_MAX / 3)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%lld particles x %d directions: more slots than a kernel indexes",
                              (long long)net->particles, net->directions);
    inet_kernel k;
    kernel_make(pb, &k);
    const size_t d = (size_t)net->directions;
    vdbs_kernel_desc kd = {0};
    kd.items = (uint64_t)slots;
    kd.user = &k;
    kd.cpu_step = inet_step;
    kd.cpu_chunk = 1024;
    kd.shader = "inet_sweep.comp";
    kd.inputs[1] = (vdbs_kernel_input){k.params, sizeof k.params, pb->resident[0]};
    kd.inputs[2] = (vdbs_kernel_input){
        pb->links->source, sizeof(int32_t) * (size_t)(slots + pb->links->sinks), pb->resident[1]};
    kd.inputs[3] = (vdbs_kernel_input){pb->phase, sizeof(float) * d * d, pb->resident[2]};
    if (pb->emission)
        kd.inputs[4] = (vdbs_kernel_input){
            pb->emission, sizeof(float) * 3 * (size_t)pb->links->links, pb->resident[3]};
    kd.state = state;
    kd.state_words = 3;
    kd.max_iterations = max_iterations > 0 ? max_iterations : 1;
    kd.tolerance = tolerance;
    kd.reduce = VDBS_REDUCE_SUM;
    kd.progress = progress;
    kd.cancel = vdbs_progress_cancel(progress);
    return vdbs_kernel_iterate(runner, &kd, result, err);
}

double vdbs_inet_line_sweep(const vdbs_inet_problem *pb, const int32_t *downstream, float *state,
                            double *scratch)
{
    const vdbs_inet_network *net = pb->net;
    const int64_t N = net->particles, links = pb->links->links, sinks = pb->links->sinks;
    const int D = net->directions;
    inet_kernel k;
    kernel_make(pb, &k);
    double change = 0.0;
    for (int i = 0; i < D; ++i) {
#pragma omp parallel for schedule(dynamic, 256)
        for (int64_t head = 0; head < N; ++head) {
            scratch[head] = 0.0;
            if (net->upstream[head * D + i] >= 0)
                continue;
            /* A chain's slots in order, each from its source's newest values, in place. */
            for (int64_t p = head; p >= 0; p = downstream[p * D + i])
                scratch[head] += slot_update(&k, state, state, (int)(p * D + i));
        }
        /* In particle order, so that the change does not depend on the thread count. */
        for (int64_t head = 0; head < N; ++head)
            change += scratch[head];
    }
    /* The sinks: the light leaving each chain's end. */
    for (int64_t s = links; s < links + sinks; ++s)
        change += slot_update(&k, state, state, (int)s);
    return change;
}

/* Sweeps the contraction is averaged over, and sweeps before its estimate may end a solve. */
#define INET_RATIO_SPAN 4

vdbs_status vdbs_inet_solve(vdbs_runner *runner, const vdbs_inet_problem *pb, int max_iterations,
                            double residual, double reference, float *state,
                            vdbs_progress *progress, vdbs_inet_solve_result *result,
                            vdbs_error *err)
{
    vdbs_inet_solve_result res = {0};
    vdbs_inet_problem p = *pb;
    const int gpu = vdbs_runner_backend(runner) == VDBS_BACKEND_GPU;
    for (int i = 0; i < 4 && gpu; ++i)
        if (!p.resident[i])
            p.resident[i] = vdbs_runner_resident_id(runner);
    if (!(reference > 0.0))
        reference = 1.0;
    double changes[INET_RATIO_SPAN + 1] = {0};
    vdbs_status st = VDBS_OK;
    for (int it = 0; it < max_iterations && st == VDBS_OK; ++it) {
        vdbs_kernel_result kr = {0};
        st = vdbs_inet_iterate(runner, &p, 1, 0.0, state, NULL, &kr, err);
        if (st != VDBS_OK)
            break;
        memmove(changes + 1, changes, sizeof changes[0] * INET_RATIO_SPAN);
        changes[0] = kr.reduction / reference;
        res.iterations = it + 1;
        res.change = changes[0];
        double rho = 1.0;
        if (res.iterations > INET_RATIO_SPAN) {
            double sum = 0.0;
            for (int k = 0; k < INET_RATIO_SPAN; ++k)
                sum += changes[k + 1] > 0.0 ? changes[k] / changes[k + 1] : 0.0;
            rho = sum / INET_RATIO_SPAN;
        }
        res.contraction = rho;
        res.residual = changes[0] == 0.0 ? 0.0
                       : rho < 1.0       ? changes[0] * fmax(rho / (1.0 - rho), 1.0)
                                         : HUGE_VAL;
        if (progress)
            vdbs_progress_update(progress, (uint64_t)res.iterations);
        if (res.residual <= residual) {
            res.converged = 1;
            break;
        }
        if (vdbs_progress_cancelled(progress))
            st = vdbs_error_cancelled(err);
    }
    for (int i = 0; i < 4 && gpu; ++i)
        if (!pb->resident[i])
            vdbs_runner_release(runner, p.resident[i]);
    if (result)
        *result = res;
    return st;
}

vdbs_status vdbs_inet_setup_build(const vdbs_volume *volume, double density_scale, double g,
                                  int64_t particles, int directions, int window, uint64_t seed,
                                  vdbs_inet_setup *setup, vdbs_error *err)
{
    memset(setup, 0, sizeof *setup);
    vdbs_phasemat_desc pdesc = {directions, g, -1};
    vdbs_status st = vdbs_phasemat_build(&pdesc, &setup->pm, err);
    const size_t D = (size_t)directions;
    if (st == VDBS_OK && !(setup->phase = malloc(sizeof *setup->phase * D * D)))
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %d directions", directions);
    if (st == VDBS_OK) {
        for (size_t i = 0; i < D * D; ++i)
            setup->phase[i] = (float)setup->pm.p[i];
        vdbs_inet_network_desc nd = {particles, window, seed};
        st = vdbs_inet_network_build(volume, density_scale, setup->pm.dirs, directions, &nd,
                                     &setup->net, err);
    }
    if (st == VDBS_OK)
        st = vdbs_inet_links_build(&setup->net, &setup->links, err);
    if (st != VDBS_OK)
        vdbs_inet_setup_free(setup);
    return st;
}

void vdbs_inet_setup_free(vdbs_inet_setup *setup)
{
    vdbs_inet_links_free(&setup->links);
    vdbs_inet_network_free(&setup->net);
    free(setup->phase);
    vdbs_phasemat_free(&setup->pm);
    memset(setup, 0, sizeof *setup);
}

double vdbs_inet_balance(const vdbs_inet_problem *pb, const float *before, const float *after)
{
    const vdbs_inet_network *net = pb->net;
    const int64_t links = pb->links->links, slots = links + pb->links->sinks;
    const int dirs = net->directions;
    double sent = 0.0, held = 0.0;
    for (int64_t s = 0; s < slots; ++s)
        for (int ch = 0; ch < 3; ++ch) {
            if (pb->links->source[s] >= 0)
                held += after[3 * s + ch];
        }
    for (int64_t p = 0; p < net->particles; ++p)
        for (int ch = 0; ch < 3; ++ch) {
            const double keep = 1.0 - pb->opacity * (1.0 - pb->albedo[ch]);
            for (int i = 0; i < dirs; ++i) {
                const int64_t at = 3 * (p * dirs + i) + ch;
                sent += keep * before[at] + (pb->emission ? pb->emission[at] : 0.0);
            }
        }
    return sent > 0.0 ? fabs(sent - held) / sent : 0.0;
}

/* ---- the state on the output voxels ---- */

vdbs_status vdbs_inet_voxel_state_alloc(vdbs_inet_voxel_state *vs, int directions, size_t voxels,
                                        vdbs_error *err)
{
    memset(vs, 0, sizeof *vs);
    vs->radiance = calloc((size_t)(directions > 0 ? directions : 1), sizeof *vs->radiance);
    vdbs_status st =
        vs->radiance ? VDBS_OK
                     : vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the network's state");
    vs->directions = vs->radiance ? directions : 0;
    vs->voxels = voxels;
    for (int d = 0; d < vs->directions && st == VDBS_OK; ++d)
        if (!(vs->radiance[d] = calloc(3 * (voxels ? voxels : 1), sizeof *vs->radiance[d])))
            st = vdbs_error_set(err, VDBS_ERR_NOMEM,
                                "out of memory for the network's state: %d directions x %zu "
                                "voxels",
                                directions, voxels);
    if (st != VDBS_OK)
        vdbs_inet_voxel_state_free(vs);
    return st;
}

void vdbs_inet_voxel_state_free(vdbs_inet_voxel_state *vs)
{
    for (int d = 0; vs->radiance && d < vs->directions; ++d)
        free(vs->radiance[d]);
    free(vs->radiance);
    memset(vs, 0, sizeof *vs);
}

vdbs_status vdbs_inet_voxel_state_store(const vdbs_inet_network *net, const float *state,
                                        vdbs_inet_voxel_state *vs, vdbs_error *err)
{
    const int D = net->directions;
    const size_t voxels = vs->voxels;
    uint32_t *count = calloc(voxels ? voxels : 1, sizeof *count);
    double *sum = calloc(3 * (voxels ? voxels : 1), sizeof *sum);
    if (D != vs->directions || !count || !sum) {
        free(count);
        free(sum);
        return D != vs->directions
                   ? vdbs_error_set(err, VDBS_ERR_INTERNAL,
                                    "inet state: %d directions for a network of %d", vs->directions,
                                    D)
                   : vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the network's state");
    }
    for (int d = 0; d < D; ++d) {
        memset(sum, 0, sizeof *sum * 3 * voxels);
        memset(count, 0, sizeof *count * voxels);
        for (int64_t p = 0; p < net->particles; ++p) {
            const size_t v = (size_t)net->voxel[p];
            if (v >= voxels || net->upstream[p * D + d] < 0)
                continue;
            ++count[v];
            for (int ch = 0; ch < 3; ++ch)
                sum[3 * v + ch] += state[3 * (p * D + d) + ch];
        }
        float *out = vs->radiance[d];
        for (size_t v = 0; v < voxels; ++v)
            for (int ch = 0; ch < 3; ++ch)
                out[3 * v + ch] = count[v] ? (float)(sum[3 * v + ch] / count[v]) : 0.0f;
    }
    free(count);
    free(sum);
    return VDBS_OK;
}

void vdbs_inet_voxel_state_start(const vdbs_inet_network *net, const vdbs_inet_voxel_state *vs,
                                 float *state)
{
    const int D = net->directions;
    if (D != vs->directions)
        return;
#pragma omp parallel for schedule(static)
    for (int64_t p = 0; p < net->particles; ++p) {
        const size_t v = (size_t)net->voxel[p];
        if (v >= vs->voxels)
            continue;
        for (int d = 0; d < D; ++d)
            if (net->upstream[p * D + d] >= 0)
                for (int ch = 0; ch < 3; ++ch)
                    state[3 * (p * D + d) + ch] = vs->radiance[d][3 * v + ch];
    }
}

static void state_grid_name(int d, char *name, size_t size)
{
    snprintf(name, size, VDBS_INET_STATE_PREFIX "%04d", d);
}

int vdbs_inet_voxel_state_directions(const vdbio_lit *lit)
{
    const char *text = lit ? vdbio_lit_meta(lit, VDBS_INET_STATE_META) : NULL;
    const long d = text ? strtol(text, NULL, 10) : 0;
    char name[32];
    if (d < 1 || d > 100000)
        return 0;
    state_grid_name((int)d - 1, name, sizeof name);
    return vdbio_lit_has_grid(lit, name) ? (int)d : 0;
}

vdbs_status vdbs_inet_voxel_state_read(const vdbio_lit *lit, const char *path,
                                       const vdbs_volume *volume, int directions,
                                       vdbs_inet_voxel_state *vs, vdbs_error *err)
{
    memset(vs, 0, sizeof *vs);
    const int held = vdbs_inet_voxel_state_directions(lit);
    if (held == 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--warm-start %s: no illumination-network state in it (bake it "
                              "with --method inet --keep-state)",
                              path);
    if (held != directions)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--warm-start %s: its illumination-network state has %d "
                              "directions, not %d (--inet-directions)",
                              path, held, directions);
    vdbs_status st = vdbs_inet_voxel_state_alloc(vs, held, volume->coord_count, err);
    for (int d = 0; d < held && st == VDBS_OK; ++d) {
        char name[32];
        state_grid_name(d, name, sizeof name);
        st = vdbs_solve_state_vec3(lit, name, volume, vs->radiance[d], err);
    }
    if (st != VDBS_OK)
        vdbs_inet_voxel_state_free(vs);
    return st;
}

/* ---- the bake's solve ---- */

/* What a quality chooses (docs/methods/inet.md, "Presets and the ladder": 64 directions
 * measured no worse than 96, 128 or 256 on the cloud sample). The ladder stops at low (the
 * entry's ladder_stop): more particles moved the error both ways on the calibration set, so
 * every quality bakes as low. */
static const vdbs_inet_preset inet_presets[VDBS_QUALITY_COUNT] = {
    {5000, 64, 1e-2}, {5000, 64, 1e-2}, {5000, 64, 1e-2}, {5000, 64, 1e-2}};

void vdbs_inet_quality(const char *quality, vdbs_inet_preset *preset)
{
    *preset = inet_presets[vdbs_quality_level(quality)];
}

struct vdbs_inet_run {
    const vdbs_solve *s;
    vdbs_inet_desc desc;
    vdbs_inet_stats stats;
    vdbs_inet_setup setup;
    vdbs_voxel_faces faces;
    double *scratch, *rate;
    float *emission;
    double t0;
};

int64_t vdbs_inet_voxel_bytes(size_t voxels)
{
    /* sizeof only: the fields' types, as vdbs_inet_begin allocates */
    const vdbs_inet_run *r = NULL;
    return vdbs_voxel_faces_bytes(voxels) +
           (int64_t)((VDBS_COLLISION_SCRATCH * sizeof *r->scratch + 3 * sizeof *r->rate +
                      sizeof *r->setup.net.voxel_sigma_t) *
                     voxels);
}

int64_t vdbs_inet_network_bytes(int64_t particles, int directions)
{
    /* sizeof only: the fields' types, as the network, its links and the solve allocate */
    const vdbs_inet_run *r = NULL;
    const int64_t slots = particles * directions;
    /* the solve's state and the C runner's second copy of it, 3 floats a slot each */
    const int64_t state = 2 * 3 * (int64_t)sizeof(float);
    return particles * (int64_t)(3 * sizeof *r->setup.net.position + sizeof *r->setup.net.voxel) +
           slots * ((int64_t)(sizeof *r->setup.net.upstream + sizeof *r->setup.links.source +
                              3 * sizeof *r->emission) +
                    state) +
           (int64_t)directions * directions * (int64_t)sizeof *r->setup.phase;
}

void vdbs_inet_end(vdbs_inet_run *r)
{
    if (!r)
        return;
    vdbs_inet_setup_free(&r->setup);
    vdbs_voxel_faces_free(&r->faces);
    free(r->scratch);
    free(r->rate);
    free(r->emission);
    free(r);
}

vdbs_status vdbs_inet_begin(const vdbs_solve *s, const vdbs_inet_desc *desc, vdbs_inet_run **out,
                            vdbs_error *err)
{
    *out = NULL;
    vdbs_inet_run *r = calloc(1, sizeof *r);
    if (!r)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    r->s = s;
    r->desc = *desc;
    r->t0 = vdbs_now();
    vdbs_inet_preset preset;
    vdbs_inet_quality(s->quality ? s->quality->name : NULL, &preset);
    vdbs_inet_desc *d = &r->desc;
    if (d->particles <= 0)
        d->particles = preset.particles;
    if (d->directions <= 0)
        d->directions = preset.directions;
    if (!(d->residual > 0.0))
        d->residual = preset.residual;
    if (d->max_iterations <= 0)
        d->max_iterations = INET_MAX_ITERATIONS;
    const size_t voxels = s->volume->coord_count;
    vdbs_status st =
        vdbs_inet_setup_build(s->volume, s->scene->density_scale, s->scene->g, d->particles,
                              d->directions, d->window, d->seed, &r->setup, err);
    r->stats.seconds_network = vdbs_now() - r->t0;
    if (st == VDBS_OK)
        st = vdbs_voxel_faces_build(s->volume, &r->faces, err);
    if (st == VDBS_OK) {
        r->scratch = malloc(sizeof *r->scratch * VDBS_COLLISION_SCRATCH * (voxels ? voxels : 1));
        r->rate = malloc(sizeof *r->rate * 3 * (voxels ? voxels : 1));
        r->emission = calloc(3 * (size_t)r->setup.links.links, sizeof *r->emission);
        if (!r->scratch || !r->rate || !r->emission)
            st = vdbs_error_set(err, VDBS_ERR_NOMEM,
                                "out of memory for %lld particles x %d directions",
                                (long long)r->setup.net.particles, d->directions);
    }
    if (st != VDBS_OK) {
        vdbs_inet_end(r);
        return st;
    }
    *out = r;
    return VDBS_OK;
}

void vdbs_inet_emit(const vdbs_inet_network *net, double g, const double albedo[3], int64_t p,
                    const double irradiance[3], const double travel[3], float *emission)
{
    const int D = net->directions;
    /* The power the particle scatters, a m E, as radiance over a link's cross-section A and
     * solid angle 4 pi / D, spread over the directions by HG(g) about the light's travel,
     * normalised on the directions so that the power is kept. */
    const double scale = (double)D / (4.0 * VDBS_PI) * net->mass / net->pixel_area;
    pnanovdb_vec3_t t = vs_vec3((float)travel[0], (float)travel[1], (float)travel[2]);
    double norm = 0.0;
    for (int i = 0; i < D; ++i) {
        const double *wi = net->dirs + 3 * i;
        norm += vs_hg_dirs((float)g, t, vs_vec3((float)wi[0], (float)wi[1], (float)wi[2]));
    }
    if (!(norm > 0.0))
        return;
    double power[3];
    for (int ch = 0; ch < 3; ++ch)
        power[ch] = albedo[ch] * irradiance[ch] * scale / norm;
    for (int i = 0; i < D; ++i) {
        const double *wi = net->dirs + 3 * i;
        const double share =
            vs_hg_dirs((float)g, t, vs_vec3((float)wi[0], (float)wi[1], (float)wi[2]));
        for (int ch = 0; ch < 3; ++ch)
            emission[3 * (p * D + i) + ch] += (float)(power[ch] * share);
    }
}

void vdbs_inet_light_depth(void *user, int light, const float *depth)
{
    vdbs_inet_run *r = user;
    const vdbs_solve *s = r->s;
    const double t0 = vdbs_now();
    const double beam[3] = {1.0, 1.0, 1.0};
    vdbs_first_collisions(s->volume, &r->faces, s->lights, light, depth, s->scene->density_scale,
                          beam, r->scratch, r->rate, NULL);
    const vdbs_inet_network *net = &r->setup.net;
    /* Per particle the irradiance its voxel's medium collides, rate over the cube's mean
     * sigma_t: the voxel's particles carry its mass, so they carry its collisions, in the
     * dilated ring too. */
#pragma omp parallel for schedule(static)
    for (int64_t p = 0; p < net->particles; ++p) {
        const int64_t v = net->voxel[p];
        const double sigma = (double)net->voxel_sigma_t[v];
        if (!(sigma > 0.0))
            continue;
        double w[3], color[3], travel[3], irradiance[3];
        for (int a = 0; a < 3; ++a)
            w[a] = net->position[3 * p + a];
        vdbs_lights_arrival(s->lights, light, w, color, travel);
        for (int ch = 0; ch < 3; ++ch)
            irradiance[ch] = r->rate[3 * v + ch] / sigma;
        vdbs_inet_emit(net, s->scene->g, s->scene->albedo, p, irradiance, travel, r->emission);
    }
    r->stats.seconds_emission += vdbs_now() - t0;
}

/* Per particle its incoming light's fluence (3) and net flux (9, x, y, z of R, G, B), splatted
 * with equal weights onto the coarse frame and averaged per cell. */
static vdbs_status splat_particles(const vdbs_inet_network *net, const float *state,
                                   const vdbs_coarse_frame *f, double *fluence, double *flux,
                                   vdbs_error *err)
{
    const int64_t cells = vdbs_coarse_cells(f);
    const int D = net->directions;
    const double w = 4.0 * VDBS_PI / D;
    double *acc = calloc(13 * (size_t)cells, sizeof *acc);
    if (!acc)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %lld cells",
                              (long long)cells);
    for (int64_t p = 0; p < net->particles; ++p) {
        double v[13] = {0};
        for (int i = 0; i < D; ++i) {
            const float *l = state + 3 * (p * D + i);
            const double *wi = net->dirs + 3 * i;
            for (int ch = 0; ch < 3; ++ch) {
                v[ch] += w * l[ch];
                for (int a = 0; a < 3; ++a)
                    v[3 + 3 * a + ch] += w * l[ch] * wi[a];
            }
        }
        v[12] = 1.0;
        double at[3] = {net->position[3 * p], net->position[3 * p + 1], net->position[3 * p + 2]};
        vdbs_coarse_splat(f, acc, 13, at, v, 1.0);
    }
    for (int64_t c = 0; c < cells; ++c) {
        const double *a = acc + 13 * c;
        const double inv = a[12] > 0.0 ? 1.0 / a[12] : 0.0;
        for (int k = 0; k < 3; ++k)
            fluence[3 * c + k] = a[k] * inv;
        for (int k = 0; k < 9; ++k)
            flux[9 * c + k] = a[3 + k] * inv;
    }
    free(acc);
    return VDBS_OK;
}

/* The splat grid: refined while its occupied cells hold at least this many particles on average
 * (a particle's incoming radiance is a noisy estimate, its own column through each direction),
 * and never past INET_MAX_SPLAT_RES cells across; both measured on the cloud sample, where 22
 * cells were worse than 16 even at 50000 particles (docs/methods/inet.md, "Reconstruction"). */
#define INET_PARTICLES_PER_CELL 8.0
#define INET_MAX_SPLAT_RES 16

/* The finest resolution (cells across the largest extent) whose occupied cells hold on average
 * at least INET_PARTICLES_PER_CELL particles. */
static int splat_resolution(const vdbs_inet_network *net, const vdbs_volume *volume)
{
    int best = 2;
    uint8_t *seen = malloc((size_t)INET_MAX_SPLAT_RES * INET_MAX_SPLAT_RES * INET_MAX_SPLAT_RES);
    if (!seen)
        return 8;
    for (int res = 3; res <= INET_MAX_SPLAT_RES; ++res) {
        vdbs_coarse_frame f;
        if (vdbs_coarse_world_frame(volume, res, 1, &f) != res)
            break; /* never finer than the voxels */
        memset(seen, 0, (size_t)f.n[0] * f.n[1] * f.n[2]);
        int64_t occupied = 0;
        for (int64_t p = 0; p < net->particles; ++p) {
            int64_t c = 0;
            for (int a = 2; a >= 0; --a) {
                double x = ((double)net->position[3 * p + a] - f.origin[a]) / f.side[a];
                int i = (int)floor(x);
                i = i < 0 ? 0 : (i >= f.n[a] ? f.n[a] - 1 : i);
                c = c * f.n[a] + i;
            }
            occupied += !seen[c];
            seen[c] = 1;
        }
        if ((double)net->particles / (double)occupied < INET_PARTICLES_PER_CELL)
            break;
        best = res;
    }
    free(seen);
    return best;
}

/* The power scattered into the network (the first scattering's, a times the collisions), per
 * channel: its emission times a link's cross-section and solid angle. */
static void scattered_power(const vdbs_inet_problem *pb, double power[3])
{
    const vdbs_inet_network *net = pb->net;
    const int64_t slots = net->particles * net->directions;
    double sum[3] = {0.0, 0.0, 0.0};
    for (int64_t k = 0; k < slots; ++k)
        for (int ch = 0; ch < 3; ++ch)
            sum[ch] += pb->emission[3 * k + ch];
    for (int ch = 0; ch < 3; ++ch)
        power[ch] = sum[ch] * net->pixel_area * 4.0 * VDBS_PI / net->directions;
}

/* Energy: the light ms says the medium absorbs, 4 pi sum (1 - a) sigma_t ms V over the voxels
 * (sigma_t the cube's mean), may not exceed the power scattered into it. Far from that bound
 * wherever the particles are optically thin or the light diffuse; reached where a particle is
 * optically so thick (thousands per particle) that the network passes on, particle to
 * particle, light the medium would absorb inside the first: a link has no medium, and an
 * opaque particle's scattered light leaves it whole. There ms (and its moments) are scaled
 * down to the bound, per channel. scale: 1 where not bound. */
static void energy_scale(const vdbs_inet_problem *pb, const vdbs_volume *volume, const float *ms,
                         double scale[3])
{
    double power[3], absorbed[3] = {0.0, 0.0, 0.0};
    scattered_power(pb, power);
    const double to_power = 4.0 * VDBS_PI * vdbs_volume_voxel_volume(volume);
    for (size_t v = 0; v < volume->coord_count; ++v)
        for (int ch = 0; ch < 3; ++ch)
            absorbed[ch] += (1.0 - pb->albedo[ch]) * (double)pb->net->voxel_sigma_t[v] *
                            (double)ms[3 * v + ch] * to_power;
    for (int ch = 0; ch < 3; ++ch)
        scale[ch] = absorbed[ch] > power[ch] ? power[ch] / absorbed[ch] : 1.0;
}

vdbs_status vdbs_inet_to_voxels(const vdbs_inet_problem *pb, const float *state,
                                const vdbs_volume *volume, double density_scale, double g,
                                float *ms, float *const ms_l1[3], float *radiance, int *resolution,
                                vdbs_error *err)
{
    const vdbs_inet_network *net = pb->net;
    vdbs_coarse_frame f;
    const int res = vdbs_coarse_world_frame(volume, splat_resolution(net, volume), 1, &f);
    if (resolution)
        *resolution = res;
    const int64_t cells = vdbs_coarse_cells(&f);
    double *fluence = malloc(sizeof *fluence * 3 * (size_t)cells);
    double *flux = malloc(sizeof *flux * 9 * (size_t)cells);
    double *values = malloc(sizeof *values * VDBS_COARSE_WIDTH * (size_t)cells);
    vdbs_medium_box box = {0};
    vdbs_status st = VDBS_OK;
    if (!fluence || !flux || !values)
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %lld cells", (long long)cells);
    if (st == VDBS_OK)
        st = splat_particles(net, state, &f, fluence, flux, err);
    if (st == VDBS_OK) {
        int block = (int)floor(f.h / volume->mean_voxel_size);
        st = vdbs_medium_box_build(volume, block < 1 ? 1 : block, &box, err);
    }
    /* Reconstructed apart, then added within the energy bound. */
    const size_t n = 3 * volume->coord_count;
    float *part = st == VDBS_OK ? calloc(5 * n, sizeof *part) : NULL;
    if (st == VDBS_OK && !part)
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu voxels",
                            volume->coord_count);
    if (st == VDBS_OK) {
        float *const part_l1[3] = {part + n, part + 2 * n, part + 3 * n};
        vdbs_coarse_ms_values(cells, fluence, flux, g, values);
        st = vdbs_coarse_upsample(&f, values, volume, &box, density_scale,
                                  VDBS_COARSE_BSPLINE_INTERP, part, part_l1, part + 4 * n, err);
    }
    if (st == VDBS_OK) {
        double scale[3] = {1.0, 1.0, 1.0};
        if (pb->emission)
            energy_scale(pb, volume, part, scale);
        for (size_t k = 0; k < n; ++k) {
            const float c = (float)scale[k % 3];
            ms[k] += c * part[k];
            for (int a = 0; a < 3; ++a)
                ms_l1[a][k] += c * part[(size_t)(1 + a) * n + k];
            if (radiance)
                radiance[k] += c * part[4 * n + k];
        }
    }
    free(part);
    vdbs_medium_box_free(&box);
    free(fluence);
    free(flux);
    free(values);
    return st;
}

vdbs_status vdbs_inet_finish(vdbs_inet_run *r, vdbs_inet_stats *stats, vdbs_error *err)
{
    const vdbs_solve *s = r->s;
    const vdbs_inet_network *net = &r->setup.net;
    vdbs_inet_stats *st_out = &r->stats;
    st_out->particles = net->particles;
    st_out->directions = net->directions;
    st_out->window = net->window;
    st_out->paper_window = net->paper_window;
    st_out->pixel_area = net->pixel_area;
    st_out->opacity = vdbs_inet_opacity(net);
    st_out->links = r->setup.links.links;
    st_out->sinks = r->setup.links.sinks;
    double first = 0.0;
    for (int64_t k = 0; k < 3 * r->setup.links.links; ++k)
        first += r->emission[k];
    st_out->first_total = first;
    const int64_t slots = r->setup.links.links + r->setup.links.sinks;
    float *state = calloc(3 * (size_t)slots, sizeof *state);
    if (!state)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %lld network slots",
                              (long long)slots);
    vdbs_inet_problem pb = {.net = net,
                            .links = &r->setup.links,
                            .phase = r->setup.phase,
                            .opacity = st_out->opacity,
                            .emission = r->emission};
    for (int ch = 0; ch < 3; ++ch)
        pb.albedo[ch] = s->scene->albedo[ch];
    const vdbs_inet_voxel_state *warm = r->desc.warm;
    if (warm && (warm->directions != net->directions || warm->voxels != s->volume->coord_count)) {
        free(state);
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "inet warm start: a state of %d directions x %zu voxels for %d x %zu",
                              warm->directions, warm->voxels, net->directions,
                              s->volume->coord_count);
    }
    if (warm)
        vdbs_inet_voxel_state_start(net, warm, state);
    st_out->warm_start = warm != NULL;
    const double t1 = vdbs_now();
    vdbs_inet_solve_result sr = {.converged = 1};
    vdbs_status st = VDBS_OK;
    if (first > 0.0) {
        if (r->desc.progress)
            vdbs_progress_begin(r->desc.progress, r->desc.progress->enabled, "inet sweeps",
                                (uint64_t)r->desc.max_iterations);
        st = vdbs_inet_solve(s->runner, &pb, r->desc.max_iterations, r->desc.residual, first, state,
                             r->desc.progress, &sr, err);
        if (r->desc.progress)
            vdbs_progress_end(r->desc.progress);
    }
    st_out->iterations = sr.iterations;
    st_out->residual = sr.residual;
    st_out->change = sr.change;
    st_out->contraction = sr.contraction;
    st_out->converged = sr.converged;
    st_out->seconds_solve = vdbs_now() - t1;
    const double t2 = vdbs_now();
    if (st == VDBS_OK && r->desc.keep) {
        st =
            vdbs_inet_voxel_state_alloc(r->desc.keep, net->directions, s->volume->coord_count, err);
        if (st == VDBS_OK)
            st = vdbs_inet_voxel_state_store(net, state, r->desc.keep, err);
    }
    if (st == VDBS_OK)
        st = vdbs_inet_to_voxels(&pb, state, s->volume, s->scene->density_scale, s->scene->g, s->ms,
                                 s->ms_l1, s->radiance, &st_out->resolution, err);
    free(state);
    st_out->seconds_splat = vdbs_now() - t2;
    if (stats)
        *stats = *st_out;
    return st;
}
