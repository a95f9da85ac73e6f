#version 450
/* The gather pass of interleaved sampling along one axis (vs_gather.h), the kernel body
 * shared with the C path. */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* Unused (no grid is read), declared for PNanoVDB.h. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer GatherBuffer { vec4 gather_data[]; };
layout(std430, binding = 2) readonly buffer ImageIn { float image_in[]; };
layout(std430, binding = VS_PASS_BINDING_OUTPUT) writeonly buffer ImageOut { float image_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_gather.h"

void main()
{
    if (!vs_pass_item_valid())
        return;
    uint item = vs_pass_item();
    for (int c = 0; c < 3; ++c)
        image_out[3u * item + uint(c)] = vs_gather_channel(int(item), c);
    vs_pass_canary();
}
