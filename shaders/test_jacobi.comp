#version 450
/* The kernel runner's self-test: one Jacobi step per dispatch over ping-pong grids, with the
 * largest change of the step as the reduction (vs_stencil.h, tests/test_gl_kernel.c). */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer Rhs { float rhs[]; };
layout(std430, binding = 2) readonly buffer Dims { int dims[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { float u_in[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut { float u_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_stencil.h"

void main()
{
    /* Every invocation takes part in the group's reduction: no early return. */
    float change = 0.0f;
    if (vs_pass_item_valid()) {
        int n = int(vs_pass_item());
        float u = vs_jacobi_item(n, dims[0], dims[1], dims[2]);
        u_out[n] = u;
        change = abs(u - u_in[n]);
    }
    vs_pass_reduce(change, true);
    vs_pass_canary();
}
