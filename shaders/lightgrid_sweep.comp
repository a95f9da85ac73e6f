#version 450
/* Light-grid sweep (vs_lightgrid.h): one invocation per column of a tile, the kernel body
 * shared with the C path. Column c0 + item of grid `grid` is marched once and its n2 depth
 * samples are written to sweep_out[item * n2 ...]. */
#define PNANOVDB_GLSL
#define VS_LGRID_SWEEP
#include "vs_pass.h"
layout(local_size_x = VS_PASS_LOCAL_SIZE) in;

layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer MediumBuffer { vec4 medium_data[]; };
/* The set's count, headers and radii (no columns yet). */
layout(std430, binding = 2) readonly buffer LightGridBuffer { uint lgrid_data[]; };
/* (grid, first column of the tile, 0, 0) */
layout(std430, binding = 3) readonly buffer SweepParams { uint sweep_params[]; };
layout(std430, binding = VS_PASS_BINDING_OUTPUT) writeonly buffer SweepOut { float sweep_out[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_medium.h"
#include "vs_lightgrid.h"

void main()
{
    if (!vs_pass_item_valid())
        return;
    uint item = vs_pass_item();
    int grid = int(sweep_params[0]);
    uint column = sweep_params[1] + item;
    uint n0 = uint(vs_lgrid_n(grid, 0));
    uint n2 = uint(vs_lgrid_n(grid, 2));
    pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    vs_lgrid_sweep_column(buf, acc, grid, int(column % n0), int(column / n0), item * n2);
    vs_pass_canary();
}
