#version 450
/* The viewer's homogeneous fog over the rendered picture (vs_fogpass.h), the kernel body
 * shared with the C path. */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* Unused (no grid is read), declared for PNanoVDB.h. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer PassBuffer { vec4 pass_data[]; };
layout(std430, binding = 2) readonly buffer LightBuffer { vec4 light_data[]; };
layout(std430, binding = 3) readonly buffer FogBuffer { float fog_data[]; };
layout(std430, binding = 4) readonly buffer ShadowBuffer { float shadow_data[]; };
layout(std430, binding = 5) readonly buffer BackdropBuffer { vec4 backdrop_data[]; };
layout(std430, binding = 6) readonly buffer ImageIn { float image_in[]; };
/* Unused (vs_lights.h's point-light helper names it). */
layout(std430, binding = 7) readonly buffer MediumBuffer { vec4 medium_data[]; };
layout(std430, binding = VS_PASS_BINDING_OUTPUT) writeonly buffer ImageOut { float image_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_phase.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_shadow.h"
#include "vs_fog.h"
#include "vs_fogpass.h"

void main()
{
    if (!vs_pass_item_valid())
        return;
    uint item = vs_pass_item();
    uint width = uint(pass_data[VS_FOGPASS_OFF_ORIGIN].w);
    vec3 behind = vec3(image_in[3u * item], image_in[3u * item + 1u], image_in[3u * item + 2u]);
    vec3 L = vs_fogpass_pixel(int(item % width), int(item / width), behind);
    image_out[3u * item] = L.x;
    image_out[3u * item + 1u] = L.y;
    image_out[3u * item + 2u] = L.z;
    vs_pass_canary();
}
