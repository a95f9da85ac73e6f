/* The kernel runner's protocol with a compute shader (vdbscatter/gpu/runner.c is the host side).
 * Compiled as C for the names and as GLSL for the buffers and helpers.
 *
 * Why passes: Mesa's llvmpipe ends every loop of a shader invocation after 65535
 * iterations in total (all loops of the invocation together), silently, and the results
 * are simply wrong. So a long per-item job is cut into units (a unit is one march or
 * another bounded piece of work); a dispatch runs at most `units` units of every item and
 * keeps the item's progress in a state buffer, ping-ponged between dispatches. A canary
 * loop at the end of the invocation detects a dispatch that hit the limit (once it is hit
 * every loop stops after one trip, the canary's too): the runner then repeats the dispatch
 * from the same input states with half the units. Iterative solvers use the same buffers:
 * one dispatch per iteration over ping-pong grids, with a reduction after each.
 *
 * A shader that follows the protocol defines PNANOVDB_GLSL, includes this header after
 * vs_common.h, takes its item from vs_pass_item(), returns when vs_pass_item_valid() is
 * false, calls vs_pass_item_left() for items with units still to run, and ends with
 * vs_pass_canary(). Reductions write one partial per work group (vs_pass_reduce_*). */
#ifndef VS_PASS_H
#define VS_PASS_H

/* Control words, read back by the host after every dispatch. */
#define VS_PASS_UNITS 0        /* units per item in this dispatch */
#define VS_PASS_DONE 1         /* units already run per item; 0 = fresh states */
#define VS_PASS_CANARY_TRIPS 2 /* canary loop trip count */
#define VS_PASS_CANARY_STEP 3  /* 1: the canary adds it CANARY_TRIPS times */
#define VS_PASS_LEFT 4         /* out: items with units still to run */
#define VS_PASS_FAILED 5       /* out: non-zero when the loop limit was reached */
#define VS_PASS_WORDS 6

/* Buffer bindings the runner owns; a kernel's own inputs use bindings 0..7. */
#define VS_PASS_BINDING_CONTROL 8
#define VS_PASS_BINDING_STATE_IN 9
#define VS_PASS_BINDING_STATE_OUT 10
#define VS_PASS_BINDING_OUTPUT 11
#define VS_PASS_BINDING_REDUCE 12
#define VS_PASS_MAX_INPUTS 8

/* Work-group size of every runner kernel (layout(local_size_x = VS_PASS_LOCAL_SIZE)). */
#define VS_PASS_LOCAL_SIZE 64

#if defined(PNANOVDB_GLSL)

layout(std430, binding = VS_PASS_BINDING_CONTROL) coherent buffer VsPassControl
{
    uint vs_pass_control[];
};

uniform uint u_item_offset;
uniform uint u_item_count;

uint vs_pass_item()
{
    return u_item_offset + gl_GlobalInvocationID.x;
}

bool vs_pass_item_valid()
{
    return vs_pass_item() < u_item_count;
}

int vs_pass_units()
{
    return int(vs_pass_control[VS_PASS_UNITS]);
}

int vs_pass_done()
{
    return int(vs_pass_control[VS_PASS_DONE]);
}

/* The item still has work after this dispatch. */
void vs_pass_item_left()
{
    atomicAdd(vs_pass_control[VS_PASS_LEFT], 1u);
}

/* Last statement of main(): flags a dispatch whose loops were cut short. */
void vs_pass_canary()
{
    uint canary = 0u;
    for (uint i = 0u; i < vs_pass_control[VS_PASS_CANARY_TRIPS]; ++i)
        canary += vs_pass_control[VS_PASS_CANARY_STEP];
    if (canary != vs_pass_control[VS_PASS_CANARY_TRIPS] * vs_pass_control[VS_PASS_CANARY_STEP])
        atomicOr(vs_pass_control[VS_PASS_FAILED], 1u);
}

/* Reduction: every invocation of the group calls one of these (invalid items with the
 * neutral value 0) and the group's first invocation writes the group's partial; the host
 * combines the partials in double. Call from uniform control flow. */
layout(std430, binding = VS_PASS_BINDING_REDUCE) writeonly buffer VsPassReduce
{
    float vs_pass_partials[];
};
shared float vs_pass_scratch[VS_PASS_LOCAL_SIZE];

void vs_pass_reduce(float value, bool take_max)
{
    uint lane = gl_LocalInvocationID.x;
    vs_pass_scratch[lane] = value;
    barrier();
    for (uint half_size = VS_PASS_LOCAL_SIZE / 2u; half_size > 0u; half_size /= 2u) {
        if (lane < half_size) {
            float other = vs_pass_scratch[lane + half_size];
            vs_pass_scratch[lane] =
                take_max ? max(vs_pass_scratch[lane], other) : vs_pass_scratch[lane] + other;
        }
        barrier();
    }
    /* Chunks start at whole groups, so the group's index over all chunks is this. */
    if (lane == 0u)
        vs_pass_partials[gl_WorkGroupID.x + u_item_offset / uint(VS_PASS_LOCAL_SIZE)] =
            vs_pass_scratch[0];
}

#endif

#endif
