#version 450
/* Single scattering: one invocation per output voxel; the kernel body is shared with the
 * C path (vs_single.h). The state is the fluence summed so far; the runner splits the units
 * into passes (vs_pass.h). */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer MediumBuffer { vec4 medium_data[]; };
layout(std430, binding = 2) readonly buffer LightBuffer { vec4 light_data[]; };
layout(std430, binding = 3) readonly buffer CoordBuffer { int coords[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { float fluence_in[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut { float fluence_out[]; };
layout(std430, binding = VS_PASS_BINDING_OUTPUT) writeonly buffer Output { float radiance[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_single.h"

void main()
{
    if (!vs_pass_item_valid())
        return;
    uint item = vs_pass_item();
    ivec3 ijk = ivec3(coords[3u * item], coords[3u * item + 1u], coords[3u * item + 2u]);
    int first = vs_pass_done();
    vec3 f = first == 0 ? vec3(0.0f)
                        : vec3(fluence_in[3u * item], fluence_in[3u * item + 1u],
                               fluence_in[3u * item + 2u]);
    pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    f = vs_single_accumulate(buf, acc, ijk, f, first, vs_pass_units());
    fluence_out[3u * item] = f.x;
    fluence_out[3u * item + 1u] = f.y;
    fluence_out[3u * item + 2u] = f.z;
    vec3 s = vs_vec3_scale(f, VS_INV_4PI);
    radiance[3u * item] = s.x;
    radiance[3u * item + 1u] = s.y;
    radiance[3u * item + 2u] = s.z;
    if (vs_single_units() - first > vs_pass_units())
        vs_pass_item_left();
    vs_pass_canary();
}
