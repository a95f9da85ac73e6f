#version 450
/* One POP iteration over one propagation grid (vs_pop.h), the kernel body shared with the C
 * path: every cell gathers from its six neighbours' lobes in the previous state; the
 * reduction is the energy still in transit. */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer PopParams { uint pop_params[]; };
layout(std430, binding = 2) readonly buffer PopSigma { float pop_sigma[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { float pop_state_in[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut
{
    float pop_state_out[];
};

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_pop.h"

void main()
{
    /* Every invocation takes part in the group's reduction: no early return. */
    float energy = 0.0f;
    if (vs_pass_item_valid()) {
        int cell = int(vs_pass_item());
        energy = vs_pop_gather(cell, cell * VS_POP_STATE_WORDS);
    }
    vs_pass_reduce(energy, false);
    vs_pass_canary();
}
