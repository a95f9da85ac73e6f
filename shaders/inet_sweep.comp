#version 450
/* One Jacobi sweep of an illumination network (vs_inet.h), the kernel body shared with the C
 * path: every item is a slot, its new radiance from the old state; the reduction is the sum of
 * the slots' changes over the channels. */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer InetParams { uint inet_params[]; };
layout(std430, binding = 2) readonly buffer InetSource { int inet_source[]; };
layout(std430, binding = 3) readonly buffer InetPhase { float inet_phase[]; };
layout(std430, binding = 4) readonly buffer InetEmission { float inet_emission[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { float inet_in[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut { float inet_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_inet.h"

void main()
{
    /* Every invocation takes part in the group's reduction: no early return. */
    float change = 0.0f;
    if (vs_pass_item_valid()) {
        int s = int(vs_pass_item());
        pnanovdb_vec3_t l = vs_inet_slot(s);
        inet_out[3 * s] = l.x;
        inet_out[3 * s + 1] = l.y;
        inet_out[3 * s + 2] = l.z;
        change = abs(l.x - inet_in[3 * s]) + abs(l.y - inet_in[3 * s + 1]) +
                 abs(l.z - inet_in[3 * s + 2]);
    }
    vs_pass_reduce(change, false);
    vs_pass_canary();
}
