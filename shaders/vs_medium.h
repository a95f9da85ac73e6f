/* The medium table: what every kernel needs to know of the volume besides its density
 * grid (sigma_t = density * density_scale, sigma_s = albedo sigma_t, HG g, the affine map
 * both ways and the support box), written by vdbscatter/medium/medium.c. Include after
 * vs_common.h. Named offsets and accessors, one vec4 per entry. */
#ifndef VS_MEDIUM_H
#define VS_MEDIUM_H

/* (density_scale, HG g, 0, 0) */
#define VS_MEDIUM_OFF_PARAMS 0
/* (albedo rgb, 0) */
#define VS_MEDIUM_OFF_ALBEDO 1
/* Three rows (xyz) of the linear part of index-to-world: world vectors from index ones. */
#define VS_MEDIUM_OFF_TO_WORLD 2
/* Three rows (xyz) of the linear part of world-to-index. */
#define VS_MEDIUM_OFF_TO_INDEX 5
/* Index-space support box of the interpolated density: lo (xyz), hi (xyz). */
#define VS_MEDIUM_OFF_BOX_LO 8
#define VS_MEDIUM_OFF_BOX_HI 9
#define VS_MEDIUM_SIZE 10

VS_FUNC float vs_medium_density_scale(VS_DATA_ONLY(vs_vec4, medium_data))
{
    return medium_data[VS_MEDIUM_OFF_PARAMS].x;
}

VS_FUNC float vs_medium_g(VS_DATA_ONLY(vs_vec4, medium_data))
{
    return medium_data[VS_MEDIUM_OFF_PARAMS].y;
}

VS_FUNC pnanovdb_vec3_t vs_medium_albedo(VS_DATA_ONLY(vs_vec4, medium_data))
{
    return vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_ALBEDO]);
}

VS_FUNC pnanovdb_vec3_t vs_medium_box_lo(VS_DATA_ONLY(vs_vec4, medium_data))
{
    return vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_BOX_LO]);
}

VS_FUNC pnanovdb_vec3_t vs_medium_box_hi(VS_DATA_ONLY(vs_vec4, medium_data))
{
    return vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_BOX_HI]);
}

/* World image of an index-space vector (world distances of index-space marches). */
VS_FUNC pnanovdb_vec3_t vs_medium_to_world(VS_DATA_PARAM(vs_vec4, medium_data) pnanovdb_vec3_t v)
{
    return vs_vec3(vs_vec3_dot(vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_TO_WORLD]), v),
                   vs_vec3_dot(vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_TO_WORLD + 1]), v),
                   vs_vec3_dot(vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_TO_WORLD + 2]), v));
}

/* Index-space image of a world vector. */
VS_FUNC pnanovdb_vec3_t vs_medium_to_index(VS_DATA_PARAM(vs_vec4, medium_data) pnanovdb_vec3_t v)
{
    return vs_vec3(vs_vec3_dot(vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_TO_INDEX]), v),
                   vs_vec3_dot(vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_TO_INDEX + 1]), v),
                   vs_vec3_dot(vs_vec3_from_vec4(medium_data[VS_MEDIUM_OFF_TO_INDEX + 2]), v));
}

#endif
