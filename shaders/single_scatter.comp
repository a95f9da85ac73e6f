#version 450
/* Single scattering: one invocation per output voxel; the kernel body is shared with the
 * C path (vs_single.h).
 *
 * llvmpipe ends every loop of an invocation after 65535 iterations in total, so a pass
 * runs only marches [control[0], control[0] + control[1]) of each voxel and adds them to
 * the sums of the previous pass. A canary loop at the end detects a pass that hit the
 * limit (every loop, the canary's too, then stops after one trip); the host then repeats
 * that pass, from the same input sums, with fewer marches. */
layout(local_size_x = 64) in;

#define PNANOVDB_GLSL
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer LightBuffer { vec4 light_data[]; };
layout(std430, binding = 2) readonly buffer CoordBuffer { int coords[]; };
layout(std430, binding = 3) readonly buffer SumIn { float sum_in[]; };
layout(std430, binding = 4) writeonly buffer SumOut { float sum_out[]; };
/* [0] first march, [1] march count, [2] canary trips, [3] canary step (1), [4] failed (out) */
layout(std430, binding = 5) coherent buffer Control { uint control[]; };

uniform uint u_item_offset;
uniform uint u_item_count;

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_single.h"

void main()
{
    uint item = u_item_offset + gl_GlobalInvocationID.x;
    if (item >= u_item_count)
        return;
    ivec3 ijk = ivec3(coords[3u * item], coords[3u * item + 1u], coords[3u * item + 2u]);
    vec3 s = control[0] == 0u
                 ? vec3(0.0f)
                 : vec3(sum_in[3u * item], sum_in[3u * item + 1u], sum_in[3u * item + 2u]);
    pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    s = vs_single_accumulate(buf, acc, ijk, s, int(control[0]), int(control[1]));
    sum_out[3u * item] = s.x;
    sum_out[3u * item + 1u] = s.y;
    sum_out[3u * item + 2u] = s.z;

    uint canary = 0u;
    for (uint i = 0u; i < control[2]; ++i)
        canary += control[3];
    if (canary != control[2] * control[3])
        atomicOr(control[4], 1u);
}
