#version 450
/* One application of the FLD operator (vs_fld.h) for one colour channel, the kernel body
 * shared with the C path: state_out = A state_in; the reduction is state_in . A state_in
 * (the p . Ap of conjugate gradients). */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer FldParams { uint fld_params[]; };
layout(std430, binding = 2) readonly buffer FldCoef { float fld_coef[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { float fld_x[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut { float fld_y[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_fld.h"

void main()
{
    /* Every invocation takes part in the group's reduction: no early return. */
    float xax = 0.0f;
    if (vs_pass_item_valid()) {
        int cell = int(vs_pass_item());
        float y = vs_fld_apply(cell);
        fld_y[cell] = y;
        xax = fld_x[cell] * y;
    }
    vs_pass_reduce(xax, false);
    vs_pass_canary();
}
