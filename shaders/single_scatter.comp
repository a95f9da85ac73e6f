#version 450
/* Single scattering: one invocation per output voxel; the kernel body is shared
 * with the C path (vs_single.h). */
layout(local_size_x = 64) in;

#define PNANOVDB_GLSL
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer LightBuffer { vec4 light_data[]; };
layout(std430, binding = 2) readonly buffer CoordBuffer { int coords[]; };
layout(std430, binding = 3) writeonly buffer RadianceBuffer { float radiance[]; };

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
    pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    vec3 s = vs_single_average(buf, acc, ijk);
    radiance[3u * item] = s.x;
    radiance[3u * item + 1u] = s.y;
    radiance[3u * item + 2u] = s.z;
}
