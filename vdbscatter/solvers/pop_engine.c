#include "vdbscatter/pop_engine.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_pop.h"

void vdbs_pop_grid_params(const int n[3], double h, double g, const double albedo[3],
                          const vdbs_pop_transport *transport, int keep_a, uint32_t *params)
{
    memset(params, 0, sizeof(uint32_t) * VS_POP_PARAM_WORDS);
    for (int a = 0; a < 3; ++a)
        params[VS_POP_OFF_N + a] = (uint32_t)n[a];
    float hf = (float)h, gf = (float)g;
    memcpy(&params[VS_POP_OFF_H], &hf, sizeof hf);
    memcpy(&params[VS_POP_OFF_G], &gf, sizeof gf);
    for (int c = 0; c < 3; ++c) {
        float al = (float)albedo[c];
        memcpy(&params[VS_POP_OFF_ALBEDO + c], &al, sizeof al);
    }
    params[VS_POP_OFF_DECAY] =
        transport->decay == VDBS_POP_DECAY_PAPER ? VS_POP_DECAY_PAPER : VS_POP_DECAY_MEAN_COSINE;
    params[VS_POP_OFF_KEEP_A] = keep_a ? 1u : 0u;
    params[VS_POP_OFF_CHORD] = transport->tally_cell ? 0u : 1u;
    params[VS_POP_OFF_KIND] = VS_POP_RECTILINEAR;
}

static void put_float(uint32_t *word, double v)
{
    float f = (float)v;
    memcpy(word, &f, sizeof f);
}

uint32_t *vdbs_pop_radial_params(const vdbs_radial_frame *f, double g, const double albedo[3],
                                 const vdbs_pop_transport *transport, size_t *words)
{
    const int texels = f->n[0] * f->n[1];
    const size_t radii = VS_POP_PARAM_WORDS, records = radii + (size_t)f->n[2] + 1;
    *words = records + (size_t)texels * VS_POP_TEXEL_WORDS;
    uint32_t *params = calloc(*words, sizeof *params);
    if (!params)
        return NULL;
    vdbs_pop_grid_params(f->n, 0.0, g, albedo, transport, 1, params);
    params[VS_POP_OFF_KIND] = VS_POP_RADIAL;
    params[VS_POP_OFF_WRAP] = f->map == VDBS_RADIAL_OCTAHEDRAL ? 1u : 0u;
    params[VS_POP_OFF_RADII] = (uint32_t)radii;
    params[VS_POP_OFF_TEXELS] = (uint32_t)records;
    params[VS_POP_OFF_COMPENSATE] = 1u;
    for (int k = 0; k <= f->n[2]; ++k)
        put_float(&params[radii + (size_t)k], f->radius[k]);
    for (int t = 0; t < texels; ++t) {
        uint32_t *rec = params + records + (size_t)t * VS_POP_TEXEL_WORDS;
        put_float(&rec[VS_POP_TEXEL_OMEGA], f->omega[t]);
        for (int a = 0; a < 3; ++a)
            put_float(&rec[VS_POP_TEXEL_DIR + a], f->dir[3 * t + a]);
        /* What the sides keep: 1 - sum over the neighbours the kernel's gather finds
         * (vs_pop_texel_step) of min(Omega, Omega(n)) / (4 Omega). */
        double stay = 1.0;
        for (int s = 0; s < 4; ++s) {
            int n =
                vs_pop_texel_step(params, t % f->n[0], t / f->n[0], s == 0 ? -1 : (s == 1 ? 1 : 0),
                                  s == 2 ? -1 : (s == 3 ? 1 : 0));
            float own = (float)f->omega[t], other = (float)f->omega[n >= 0 ? n : t];
            stay -= (other < own ? other : own) / (4.0 * own);
        }
        put_float(&rec[VS_POP_TEXEL_STAY], fmax(stay, 0.0));
    }
    return params;
}

/* The mean path, in units of a chord of optical thickness tau against absorption, that light
 * starting uniformly along the chord travels before it is absorbed or leaves:
 * (1 - (1 - exp(-tau)) / tau) / tau, 1/2 without absorption (series below 1e-3, where the
 * closed form cancels). */
static double first_crossing(double tau)
{
    if (tau < 1e-3)
        return 0.5 - tau / 6.0 + tau * tau / 24.0;
    return (1.0 + expm1(-tau) / tau) / tau;
}

void vdbs_pop_start_lobes(float *state, int64_t cells, double a0, int tally_cell,
                          const vdbs_radial_frame *radial, const vdbs_pop_absorption *absorption)
{
    /* Light scattered in a cell travels half a crossing on average: 1/2 L^0 (times the
     * lobe's mean chord with the chord tally, as every later crossing), less where the cell
     * absorbs it first. Without that, a cell thick in absorption counted its seed as fluence
     * over half its width while its voxels absorb it within a fraction of one, and the
     * outputs absorbed more than entered (3.4 times in the extremes matrix's slice). */
    const double chord = tally_cell ? 1.0 : (double)vs_pop_chord((float)a0);
    for (int64_t c = 0; c < cells; ++c) {
        float *cell = state + c * VS_POP_STATE_WORDS;
        const float area = radial ? (float)vdbs_radial_cell_area(radial, c) : 1.0f;
        double length = 0.0, sigma = 0.0;
        if (absorption) {
            const int64_t texels = radial ? (int64_t)radial->n[0] * radial->n[1] : 1;
            length = radial ? radial->radius[c / texels + 1] - radial->radius[c / texels]
                            : absorption->h;
            sigma = fmax((double)absorption->sigma[c], 0.0);
        }
        for (int ch = 0; ch < 3; ++ch) {
            const double tau =
                absorption ? sigma * (1.0 - absorption->albedo[ch]) * length * chord : 0.0;
            const float first = (float)(chord * first_crossing(tau));
            if (radial)
                cell[VS_POP_STATE_L + ch] /= area;
            cell[VS_POP_STATE_A + ch] = (float)a0;
            cell[VS_POP_STATE_ACC_L + ch] = first * cell[VS_POP_STATE_L + ch];
            cell[VS_POP_STATE_ACC_LA + ch] = first * cell[VS_POP_STATE_L + ch] * (float)a0;
        }
    }
}

/* ---- propagation through the runner ---- */

typedef struct pop_kernel {
    const uint32_t *params;
    const float *sigma;
} pop_kernel;

static double pop_step(void *user, int step, const void *state_in, void *state_out, uint64_t begin,
                       uint64_t end)
{
    (void)step;
    const pop_kernel *k = user;
    double energy = 0.0;
    for (uint64_t cell = begin; cell < end; ++cell)
        energy += vs_pop_gather(k->params, state_in, k->sigma, (int)cell, state_out,
                                (int)cell * VS_POP_STATE_WORDS);
    return energy;
}

vdbs_status vdbs_pop_propagate(vdbs_runner *runner, const uint32_t *params, size_t param_words,
                               const float *sigma, int64_t cells, float *state, int max_iterations,
                               double tolerance, int *iterations, double *left, vdbs_error *err)
{
    pop_kernel k = {params, sigma};
    vdbs_kernel_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.items = (uint64_t)cells;
    desc.user = &k;
    desc.cpu_step = pop_step;
    desc.shader = "pop_propagate.comp";
    desc.inputs[1] = (vdbs_kernel_input){.data = params, .size = sizeof(uint32_t) * param_words};
    desc.inputs[2] = (vdbs_kernel_input){.data = sigma, .size = sizeof(float) * (size_t)cells};
    desc.state_words = VS_POP_STATE_WORDS;
    desc.state = state;
    desc.max_iterations = max_iterations;
    desc.tolerance = tolerance;
    desc.reduce = VDBS_REDUCE_SUM;
    vdbs_kernel_result result;
    memset(&result, 0, sizeof result);
    vdbs_status st = vdbs_kernel_iterate(runner, &desc, &result, err);
    *iterations = result.iterations;
    *left = result.reduction;
    return st;
}
