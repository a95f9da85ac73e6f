/* The light table: every light of a scene resolved once against a volume, in the layout
 * that the C kernels and the compute shaders read (written by vdbscatter/lights/lights.c).
 * Include after vs_common.h and vs_medium.h. Layout by name, as PNanoVDB.h names its own: an entry
 * is one vec4 and every field has an offset constant and an accessor; no kernel indexes the table
 * by bare row numbers.
 *
 *   header      VS_LIGHTS_HEADER_SIZE entries
 *   direct[i]   VS_LIGHT_STRIDE entries per sun or point light, i < direct count
 *   ordinate[k] VS_ORDINATE_STRIDE entries per sky ordinate, k < ordinate count
 *
 * Directions follow docs/design.md: a sun's `world` is its unit direction of travel; an
 * ordinate's `world` points towards the sky it sees. `index` fields are what marches use:
 * the index-space image of a unit world step towards the light (suns, ordinates) or the
 * light's index-space position (points). Colours are as given (irradiance W/m^2 for a
 * sun, intensity W/sr for a point); an ordinate carries its radiance times its solid-angle
 * weight, so that sum_k weighted_k f(w_k) integrates the sky's radiance against f. */
#ifndef VS_LIGHTS_H
#define VS_LIGHTS_H

/* Light types: the values of vdbs_light_type (scene.h; lights.c checks they agree). */
#define VS_LIGHT_SUN 0
#define VS_LIGHT_POINT 1
#define VS_LIGHT_ENV 2

/* Header: (direct count, ordinate count, minimum point-light distance, 0),
 * (background radiance seen by rays that leave the volume, 0). */
#define VS_LIGHTS_OFF_COUNTS 0
#define VS_LIGHTS_OFF_BACKGROUND 1
#define VS_LIGHTS_HEADER_SIZE 2

/* Direct light: (type, index xyz), (world xyz, 0), (colour rgb, 0). */
#define VS_LIGHT_OFF_INDEX 0
#define VS_LIGHT_OFF_WORLD 1
#define VS_LIGHT_OFF_COLOR 2
#define VS_LIGHT_STRIDE 3

/* Sky ordinate: (index xyz, 0), (world xyz, solid-angle weight), (radiance * weight, 0). */
#define VS_ORDINATE_OFF_INDEX 0
#define VS_ORDINATE_OFF_WORLD 1
#define VS_ORDINATE_OFF_WEIGHTED 2
#define VS_ORDINATE_STRIDE 3

VS_FUNC int vs_lights_direct_count(VS_DATA_ONLY(vs_vec4, light_data))
{
    return VS_INT(light_data[VS_LIGHTS_OFF_COUNTS].x);
}

VS_FUNC int vs_lights_ordinate_count(VS_DATA_ONLY(vs_vec4, light_data))
{
    return VS_INT(light_data[VS_LIGHTS_OFF_COUNTS].y);
}

/* World distance below which a point light's 1/r^2 is clamped (half a voxel). */
VS_FUNC float vs_lights_min_distance(VS_DATA_ONLY(vs_vec4, light_data))
{
    return light_data[VS_LIGHTS_OFF_COUNTS].z;
}

VS_FUNC pnanovdb_vec3_t vs_lights_background(VS_DATA_ONLY(vs_vec4, light_data))
{
    return vs_vec3_from_vec4(light_data[VS_LIGHTS_OFF_BACKGROUND]);
}

VS_FUNC int vs_light_entry(int i, int field)
{
    return VS_LIGHTS_HEADER_SIZE + VS_LIGHT_STRIDE * i + field;
}

VS_FUNC int vs_light_type(VS_DATA_PARAM(vs_vec4, light_data) int i)
{
    return VS_INT(light_data[vs_light_entry(i, VS_LIGHT_OFF_INDEX)].x);
}

VS_FUNC pnanovdb_vec3_t vs_light_index(VS_DATA_PARAM(vs_vec4, light_data) int i)
{
    vs_vec4 e = light_data[vs_light_entry(i, VS_LIGHT_OFF_INDEX)];
    return vs_vec3(e.y, e.z, e.w);
}

VS_FUNC pnanovdb_vec3_t vs_light_world(VS_DATA_PARAM(vs_vec4, light_data) int i)
{
    return vs_vec3_from_vec4(light_data[vs_light_entry(i, VS_LIGHT_OFF_WORLD)]);
}

VS_FUNC pnanovdb_vec3_t vs_light_color(VS_DATA_PARAM(vs_vec4, light_data) int i)
{
    return vs_vec3_from_vec4(light_data[vs_light_entry(i, VS_LIGHT_OFF_COLOR)]);
}

VS_FUNC int vs_ordinate_entry(VS_DATA_PARAM(vs_vec4, light_data) int k, int field)
{
    return VS_LIGHTS_HEADER_SIZE +
           VS_LIGHT_STRIDE * vs_lights_direct_count(VS_DATA_ONLY_ARG(light_data)) +
           VS_ORDINATE_STRIDE * k + field;
}

VS_FUNC pnanovdb_vec3_t vs_ordinate_index(VS_DATA_PARAM(vs_vec4, light_data) int k)
{
    return vs_vec3_from_vec4(
        light_data[vs_ordinate_entry(VS_DATA_ARG(light_data) k, VS_ORDINATE_OFF_INDEX)]);
}

VS_FUNC pnanovdb_vec3_t vs_ordinate_world(VS_DATA_PARAM(vs_vec4, light_data) int k)
{
    return vs_vec3_from_vec4(
        light_data[vs_ordinate_entry(VS_DATA_ARG(light_data) k, VS_ORDINATE_OFF_WORLD)]);
}

VS_FUNC float vs_ordinate_weight(VS_DATA_PARAM(vs_vec4, light_data) int k)
{
    return light_data[vs_ordinate_entry(VS_DATA_ARG(light_data) k, VS_ORDINATE_OFF_WORLD)].w;
}

/* Radiance times solid-angle weight. */
VS_FUNC pnanovdb_vec3_t vs_ordinate_weighted(VS_DATA_PARAM(vs_vec4, light_data) int k)
{
    return vs_vec3_from_vec4(
        light_data[vs_ordinate_entry(VS_DATA_ARG(light_data) k, VS_ORDINATE_OFF_WEIGHTED)]);
}

/* A point light seen from index-space point p: the index offset to it, its world image,
 * the world distance and the clamped 1/r^2. Needs vs_medium.h for the map. */
struct vs_point_view {
    pnanovdb_vec3_t offset; /* index space, p to the light */
    pnanovdb_vec3_t world;  /* the same offset in world units */
    float distance;         /* |world| */
    float falloff;          /* 1 / max(distance, minimum distance)^2 */
};
PNANOVDB_STRUCT_TYPEDEF(vs_point_view)

VS_FUNC vs_point_view vs_point_light_view(VS_DATA_PARAM(vs_vec4, medium_data)
                                              VS_DATA_PARAM(vs_vec4, light_data) int i,
                                          pnanovdb_vec3_t p)
{
    pnanovdb_vec3_t at = vs_light_index(VS_DATA_ARG(light_data) i);
    vs_point_view v;
    v.offset = vs_vec3(at.x - p.x, at.y - p.y, at.z - p.z);
    v.world = vs_medium_to_world(VS_DATA_ARG(medium_data) v.offset);
    v.distance = vs_sqrt(vs_vec3_dot(v.world, v.world));
    float rc = vs_max(v.distance, vs_lights_min_distance(VS_DATA_ONLY_ARG(light_data)));
    v.falloff = 1.0f / (rc * rc);
    return v;
}

#endif
