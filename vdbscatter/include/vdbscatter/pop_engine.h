/* POP's propagation engine (Elek et al. 2014, Secs. 3-6): a grid's parameter words, the
 * lobes that seeded light starts as, and the cell-by-cell gather through the runner
 * (shaders/vs_pop.h). The POP solver (pop.h) and the camera's importance (importance.h)
 * both propagate with it. */
#ifndef VDBSCATTER_POP_ENGINE_H
#define VDBSCATTER_POP_ENGINE_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/radial.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbs_pop_decay {
    VDBS_POP_DECAY_MEAN_COSINE = 0, /* a exp(-sigma_s t (1 - g)): exact first moment */
    VDBS_POP_DECAY_PAPER = 1        /* a g^(sigma_s t) (Eq. 4; g >= 0 only) */
} vdbs_pop_decay;

/* How a lobe moves: its anisotropy's decay law and what a cell crossing deposits.
 * Zero-initialised: the mean-cosine law and the chord tally. */
typedef struct vdbs_pop_transport {
    vdbs_pop_decay decay;
    int tally_cell; /* 1: a crossing deposits the fluence of one cell side (the paper's);
                       0: of the lobe's mean chord (shaders/vs_pop.h vs_pop_chord) */
} vdbs_pop_transport;

/* The header words (VS_POP_PARAM_WORDS) of a rectilinear grid of n cells of side h for a
 * medium of HG g and albedo; keep_a: the lobes keep their anisotropy (else isotropic). */
void vdbs_pop_grid_params(const int n[3], double h, double g, const double albedo[3],
                          const vdbs_pop_transport *transport, int keep_a, uint32_t *params);

/* Iterations of one propagation grid through the runner (shaders/pop_propagate.comp, or the
 * C loop over the same gather): params is the grid's param_words words (VS_POP_PARAM_WORDS,
 * and a radial grid's tables after them), sigma its sigma_t per cell, state cells x
 * VS_POP_STATE_WORDS floats in and out. Stops after max_iterations or once the energy in
 * transit (sum of L; of L A on radial grids) is <= tolerance; reports the iterations run and
 * that energy. */
vdbs_status vdbs_pop_propagate(vdbs_runner *runner, const uint32_t *params, size_t param_words,
                               const float *sigma, int64_t cells, float *state, int max_iterations,
                               double tolerance, int *iterations, double *left, vdbs_error *err);

/* The medium a grid's seeded light is absorbed in on its first crossing: sigma_t per cell (the
 * propagation's; < 0 counts as 0), the albedo per channel and, on a rectilinear grid, the cell
 * side (a radial cell's length is its shell's thickness). */
typedef struct vdbs_pop_absorption {
    const float *sigma;
    const double *albedo;
    double h;
} vdbs_pop_absorption;

/* Turns seeded light into lobes: the L of every cell and channel (on a radial frame its power,
 * divided here by the cell's mean section A; NULL: a rectilinear grid's L) gets anisotropy a0,
 * and the accumulation starts with the half crossing the light travels on average in the
 * cell where it scattered (times the lobe's mean chord unless tally_cell), shortened by the
 * cell's absorption when `absorption` is given (NULL: none, as for the camera's importance). */
void vdbs_pop_start_lobes(float *state, int64_t cells, double a0, int tally_cell,
                          const vdbs_radial_frame *radial, const vdbs_pop_absorption *absorption);

/* The parameter words of a radial grid over frame f (shaders/vs_pop.h): the header for a medium
 * of HG g and albedo with the transport's decay law and tally, the flux-conserving compensation on,
 * then the shell radii and texel records. *words receives their count; NULL when out of memory. The
 * caller frees it. */
uint32_t *vdbs_pop_radial_params(const vdbs_radial_frame *f, double g, const double albedo[3],
                                 const vdbs_pop_transport *transport, size_t *words);

#ifdef __cplusplus
}
#endif

#endif
