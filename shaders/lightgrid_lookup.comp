#version 450
/* Light-grid lookup (vs_lightgrid.h) at every output voxel: the optical depth towards the
 * light of one grid, the kernel body shared with the C path. */
#define PNANOVDB_GLSL
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

/* Unused (no density is read), declared for PNanoVDB.h. */
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer MediumBuffer { vec4 medium_data[]; };
layout(std430, binding = 2) readonly buffer LightGridBuffer { uint lgrid_data[]; };
/* (grid, 0, 0, 0) */
layout(std430, binding = 3) readonly buffer LookupParams { uint lookup_params[]; };
layout(std430, binding = 4) readonly buffer CoordBuffer { int coords[]; };
layout(std430, binding = VS_PASS_BINDING_OUTPUT) writeonly buffer DepthOut { float depth_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lightgrid.h"

void main()
{
    if (!vs_pass_item_valid())
        return;
    uint item = vs_pass_item();
    vec3 p = vec3(float(coords[3u * item]), float(coords[3u * item + 1u]),
                  float(coords[3u * item + 2u]));
    depth_out[item] = vs_lgrid_depth(int(lookup_params[0]), p);
    vs_pass_canary();
}
