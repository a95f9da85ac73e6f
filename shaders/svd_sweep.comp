#version 450
/* One step of a discrete-ordinates transport sweep (vs_svd.h), the kernel body shared with
 * the C path: every item is a column, every step a plane of one octant's chunk of directions,
 * the state shared by all steps (in place). */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer SvdParams { uint svd_params[]; };
layout(std430, binding = 2) readonly buffer SvdTables { float svd_tables[]; };
layout(std430, binding = 3) readonly buffer SvdSigma { float svd_sigma[]; };
layout(std430, binding = 4) readonly buffer SvdDirect { float svd_direct[]; };
layout(std430, binding = 5) readonly buffer SvdSource { float svd_source[]; };
/* In place the runner binds one buffer to both state bindings; the sweep reads back what it
 * wrote (the planes, the moments it accumulates), so it uses one read-write binding. */
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) buffer SvdState { float svd_state[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_phase.h"
#include "vs_svd.h"

void main()
{
    if (vs_pass_item_valid())
        vs_svd_sweep(int(vs_pass_item()), vs_pass_done());
    vs_pass_reduce(0.0f, false);
    vs_pass_canary();
}
