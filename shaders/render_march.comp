#version 450
/* Ray-marched picture (`render --mode single|baked`): one invocation per pixel, the kernel
 * body shared with the C path (vs_render.h). Each dispatch runs at most vs_pass_units()
 * units of a pixel's ray and keeps the ray's state between dispatches (vs_pass.h). */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* The density grid at byte 0, then the ms / ms_l1* grids at the offsets in render_data. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer MediumBuffer { vec4 medium_data[]; };
layout(std430, binding = 2) readonly buffer LightBuffer { vec4 light_data[]; };
layout(std430, binding = 3) readonly buffer RenderBuffer { vec4 render_data[]; };
/* The light grids (a count of 0 when the lights are marched). */
layout(std430, binding = 4) readonly buffer LightGridBuffer { uint lgrid_data[]; };
/* The environment map (vs_envmap.h; a zero header without one). */
layout(std430, binding = 5) readonly buffer EnvBuffer { float env_data[]; };
/* Occluders' shadow maps (vs_shadow.h; a zero count without occluders). */
layout(std430, binding = 6) readonly buffer ShadowBuffer { float shadow_data[]; };
/* Per pixel (distance to the first solid surface, its radiance), when the table says so. */
layout(std430, binding = 7) readonly buffer BackdropBuffer { vec4 backdrop_data[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_IN) readonly buffer StateIn { uint state_in[]; };
layout(std430, binding = VS_PASS_BINDING_STATE_OUT) writeonly buffer StateOut { uint state_out[]; };
layout(std430, binding = VS_PASS_BINDING_OUTPUT) writeonly buffer ImageBuffer { float image_rgb[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_phase.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_lightgrid.h"
#include "vs_envmap.h"
#include "vs_shadow.h"
#include "vs_render.h"

void main()
{
    if (!vs_pass_item_valid())
        return;
    uint item = vs_pass_item();
    uint width = uint(vs_render_width());
    vs_render_ray_info ray = vs_render_camera_ray(int(item % width), int(item / width));
    vs_render_state st = vs_pass_done() == 0 ? vs_render_state_init(ray) : vs_render_state_load(item);
    if (st.stop != 2) {
        pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
        vs_render_accessors accs = vs_render_accessors_init(buf);
        vs_render_advance(buf, accs, ray, st, vs_pass_units());
    }
    vs_render_state_store(item, st);
    vec3 radiance = vs_render_result(ray, st);
    image_rgb[3u * item] = radiance.x;
    image_rgb[3u * item + 1u] = radiance.y;
    image_rgb[3u * item + 2u] = radiance.z;
    if (st.stop != 2)
        vs_pass_item_left();
    vs_pass_canary();
}
