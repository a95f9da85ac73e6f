#version 450
/* The kernel runner's self-test of in-place sweeps: one plane per dispatch, each reading the
 * plane before it, with the plane's sum as the reduction (vs_stencil.h,
 * tests/test_gl_kernel.c). */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer Rhs { float rhs[]; };
/* One buffer bound twice (in place): the step reads plane k - 1 and writes plane k. */
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { float u_in[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut { float u_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_stencil.h"

void main()
{
    float u = 0.0f;
    if (vs_pass_item_valid()) {
        int plane = int(u_item_count);
        int n = int(vs_pass_item());
        u = vs_sweep_item(n, plane, vs_pass_done());
        u_out[n + vs_pass_done() * plane] = u;
    }
    vs_pass_reduce(u, false);
    vs_pass_canary();
}
