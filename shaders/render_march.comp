#version 450
/* Ray-marched picture (`render --mode single|baked`): one invocation per pixel, the
 * kernel body shared with the C path (vs_render.h).
 *
 * llvmpipe stops every loop of an invocation after 65535 iterations in total, so each
 * dispatch runs at most control[0] units of a pixel's ray (each unit is one march, whose
 * iterations the host bounds by the support box) and keeps the ray's state between
 * dispatches. A canary loop at the end checks that the limit was not reached: were it
 * reached, every loop would run once, the canary too, and the host repeats the dispatch
 * from the same input states with fewer units. */
layout(local_size_x = 64) in;

#define PNANOVDB_GLSL
/* The density grid at byte 0, then the ms / ms_l1* grids at the offsets in render_data. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer RenderBuffer { vec4 render_data[]; };
layout(std430, binding = 2) writeonly buffer ImageBuffer { float image_rgb[]; };
layout(std430, binding = 3) readonly buffer StateIn { uint state_in[]; };
layout(std430, binding = 4) writeonly buffer StateOut { uint state_out[]; };
/* [0] units per pixel in this dispatch, [1] 1 on the first dispatch (fresh states),
 * [2] canary trip count, [3] canary step (1), [4] pixels not done (out),
 * [5] canary failed (out) */
layout(std430, binding = 5) coherent buffer Control { uint control[]; };

uniform uint u_item_offset;
uniform uint u_item_count;

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_phase.h"
#include "vs_render.h"

#define STATE_WORDS 16u

vs_render_state load_state(uint item)
{
    uint s = STATE_WORDS * item;
    vs_render_state st;
    st.seg = int(state_in[s]);
    st.unit = int(state_in[s + 1u]);
    st.stop = int(state_in[s + 2u]);
    st.tau.sum = uintBitsToFloat(state_in[s + 3u]);
    st.tau.carry = uintBitsToFloat(state_in[s + 4u]);
    st.transmittance = uintBitsToFloat(state_in[s + 5u]);
    st.weight = uintBitsToFloat(state_in[s + 6u]);
    st.sky_sum = uintBitsToFloat(state_in[s + 7u]);
    st.source = vec3(uintBitsToFloat(state_in[s + 8u]), uintBitsToFloat(state_in[s + 9u]),
                     uintBitsToFloat(state_in[s + 10u]));
    st.radiance = vec3(uintBitsToFloat(state_in[s + 11u]), uintBitsToFloat(state_in[s + 12u]),
                       uintBitsToFloat(state_in[s + 13u]));
    return st;
}

void store_state(uint item, vs_render_state st)
{
    uint s = STATE_WORDS * item;
    state_out[s] = uint(st.seg);
    state_out[s + 1u] = uint(st.unit);
    state_out[s + 2u] = uint(st.stop);
    state_out[s + 3u] = floatBitsToUint(st.tau.sum);
    state_out[s + 4u] = floatBitsToUint(st.tau.carry);
    state_out[s + 5u] = floatBitsToUint(st.transmittance);
    state_out[s + 6u] = floatBitsToUint(st.weight);
    state_out[s + 7u] = floatBitsToUint(st.sky_sum);
    state_out[s + 8u] = floatBitsToUint(st.source.x);
    state_out[s + 9u] = floatBitsToUint(st.source.y);
    state_out[s + 10u] = floatBitsToUint(st.source.z);
    state_out[s + 11u] = floatBitsToUint(st.radiance.x);
    state_out[s + 12u] = floatBitsToUint(st.radiance.y);
    state_out[s + 13u] = floatBitsToUint(st.radiance.z);
}

void main()
{
    uint item = u_item_offset + gl_GlobalInvocationID.x;
    if (item >= u_item_count)
        return;
    uint width = uint(render_data[14].w);
    vs_render_ray_info ray = vs_render_camera_ray(int(item % width), int(item / width));
    vs_render_state st = control[1] != 0u ? vs_render_state_init(ray) : load_state(item);
    if (st.stop != 2) {
        pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
        vs_render_accessors accs = vs_render_accessors_init(buf);
        vs_render_advance(buf, accs, ray, st, int(control[0]));
    }
    store_state(item, st);
    vec3 radiance = vs_render_result(st);
    image_rgb[3u * item] = radiance.x;
    image_rgb[3u * item + 1u] = radiance.y;
    image_rgb[3u * item + 2u] = radiance.z;
    if (st.stop != 2)
        atomicAdd(control[4], 1u);

    uint canary = 0u;
    for (uint i = 0u; i < control[2]; ++i)
        canary += control[3];
    if (canary != control[2] * control[3])
        atomicOr(control[5], 1u);
}
