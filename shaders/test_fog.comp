#version 450
/* The homogeneous-fog kernels (vs_fog.h) per item, for tests/test_gl_fog.c: each item reads
 * VS_FOG_TEST_ITEM_FLOATS inputs and writes the point span, the sun span and the surface
 * term. The C side evaluates the same header functions on the same floats. */
#define PNANOVDB_GLSL
layout(local_size_x = 64) in;

/* vs_common.h speaks PNanoVDB's types; this kernel reads no grid. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer FogData { float fog_data[]; };
layout(std430, binding = 2) readonly buffer FogIn { float fog_in[]; };
layout(std430, binding = 3) writeonly buffer FogOut { float fog_out[]; };

uniform uint u_item_offset;
uniform uint u_item_count;

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_phase.h"
#include "vs_fog.h"

/* Scene floats first (sun direction, irradiance, box lo, box hi), then the items: o, s_enter,
 * d, s0, light, s1, l, cos_phi_n, sun s0, sun s1. */
#define VS_FOG_TEST_SCENE_FLOATS 12
#define VS_FOG_TEST_ITEM_FLOATS 16

pnanovdb_vec3_t in3(int k)
{
    return vs_vec3(fog_in[k], fog_in[k + 1], fog_in[k + 2]);
}

void main()
{
    uint item = u_item_offset + gl_GlobalInvocationID.x;
    if (item >= u_item_count)
        return;
    int b = VS_FOG_TEST_SCENE_FLOATS + int(item) * VS_FOG_TEST_ITEM_FLOATS;
    pnanovdb_vec3_t o = in3(b);
    pnanovdb_vec3_t d = in3(b + 4);
    float s_enter = fog_in[b + 3];
    fog_out[3 * item] = vs_fog_point_span(o, d, in3(b + 8), 2.0f, s_enter, fog_in[b + 7], fog_in[b + 11]);
    fog_out[3 * item + 1] = vs_fog_sun_span(o, d, in3(0), fog_in[3], in3(4), in3(8), fog_in[b + 14],
                                            fog_in[b + 14], fog_in[b + 15]);
    fog_out[3 * item + 2] = vs_fog_surface_indirect(fog_in[b + 12], fog_in[b + 13], 2.0f, 0.7f);
}
