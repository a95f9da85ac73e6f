/* Shadow maps of solid occluders (the viewer's OBJ meshes and primitives), shared by C and
 * GLSL: an orthographic depth map per sun and a cube of distance maps per point light
 * (Toth and Umenhoffer 2009, 4), rendered by the viewer's rasteriser and read here with
 * 2 x 2 percentage-closer filtering. A float table (an SSBO `shadow_data` in GLSL); a table
 * whose count is 0 means "no occluders": everything is visible. Include after vs_common.h.
 *
 * Sun maps: texel (i, j) of a res x res map holds, at the point
 * origin + ((i + 0.5) / res * 2 - 1) half u + ((j + 0.5) / res * 2 - 1) half v,
 * the depth along w (the direction the light travels) of the first occluder from the plane
 * through origin; a point p is lit when its own depth is at most that plus bias.
 * Cube maps: 6 faces of res x res, face f = 2 a + (sign < 0) for the major axis a of the
 * offset d = p - light; within it s = d[(a + 1) % 3] / |d[a]| and t = d[(a + 2) % 3] / |d[a]|
 * in [-1, 1] address the texels as above, each holding the distance from the light to the
 * first occluder. */
#ifndef VS_SHADOW_H
#define VS_SHADOW_H

/* Header: (number of light entries, 0, 0, 0). Entry k (the light table's direct light k)
 * starts at VS_SHADOW_OFF_ENTRIES + k * VS_SHADOW_ENTRY_SIZE. */
#define VS_SHADOW_OFF_COUNT 0
#define VS_SHADOW_OFF_ENTRIES 4
/* Entry fields: kind (VS_SHADOW_NONE / SUN / CUBE), res, first texel's float offset in the
 * table, bias (world units); origin (a sun map's plane centre, a point light's position)
 * and half (a sun map's half width); u, v, w (sun: map axes and the travel direction). */
#define VS_SHADOW_KIND 0
#define VS_SHADOW_RES 1
#define VS_SHADOW_TEXELS 2
#define VS_SHADOW_BIAS 3
#define VS_SHADOW_ORIGIN 4
#define VS_SHADOW_HALF 7
#define VS_SHADOW_U 8
#define VS_SHADOW_V 12
#define VS_SHADOW_W 16
#define VS_SHADOW_ENTRY_SIZE 20

#define VS_SHADOW_NONE 0
#define VS_SHADOW_SUN 1
#define VS_SHADOW_CUBE 2

VS_FUNC int vs_shadow_field_int(VS_DATA_PARAM(float, shadow_data) int entry, int field)
{
    return VS_INT(shadow_data[VS_SHADOW_OFF_ENTRIES + entry * VS_SHADOW_ENTRY_SIZE + field]);
}

VS_FUNC float vs_shadow_field(VS_DATA_PARAM(float, shadow_data) int entry, int field)
{
    return shadow_data[VS_SHADOW_OFF_ENTRIES + entry * VS_SHADOW_ENTRY_SIZE + field];
}

VS_FUNC pnanovdb_vec3_t vs_shadow_vec(VS_DATA_PARAM(float, shadow_data) int entry, int field)
{
    int at = VS_SHADOW_OFF_ENTRIES + entry * VS_SHADOW_ENTRY_SIZE + field;
    return vs_vec3(shadow_data[at], shadow_data[at + 1], shadow_data[at + 2]);
}

/* Filtered visibility in [0, 1] of depth `depth` at map coordinates (x, y) in [-1, 1] of
 * the res x res map at `texels`: the four nearest texels' depth tests, bilinearly
 * weighted. Outside the map: lit. */
VS_FUNC float vs_shadow_pcf(VS_DATA_PARAM(float, shadow_data) int texels, int res, float x, float y,
                            float depth, float bias)
{
    float fx = (x * 0.5f + 0.5f) * VS_FLOAT(res) - 0.5f;
    float fy = (y * 0.5f + 0.5f) * VS_FLOAT(res) - 0.5f;
    float x0 = vs_floor(fx), y0 = vs_floor(fy);
    float tx = fx - x0, ty = fy - y0;
    /* Both weights, so that fully lit and fully shadowed points are exactly 1 and 0. */
    float shadowed = 0.0f, lit = 0.0f;
    for (int k = 0; k < 4; ++k) {
        int i = VS_INT(x0) + (k & 1);
        int j = VS_INT(y0) + (k >> 1);
        float weight = ((k & 1) != 0 ? tx : 1.0f - tx) * ((k >> 1) != 0 ? ty : 1.0f - ty);
        if (i >= 0 && j >= 0 && i < res && j < res &&
            depth > shadow_data[texels + j * res + i] + bias)
            shadowed += weight;
        else
            lit += weight;
    }
    return shadowed == 0.0f ? 1.0f : lit / (lit + shadowed);
}

/* Visibility of world point p from direct light `light` (1: no occluder in between). */
VS_FUNC float vs_shadow_visibility(VS_DATA_PARAM(float, shadow_data) int light, pnanovdb_vec3_t p)
{
    if (light >= VS_INT(shadow_data[VS_SHADOW_OFF_COUNT]))
        return 1.0f;
    int kind = vs_shadow_field_int(VS_DATA_ARG(shadow_data) light, VS_SHADOW_KIND);
    if (kind == VS_SHADOW_NONE)
        return 1.0f;
    int res = vs_shadow_field_int(VS_DATA_ARG(shadow_data) light, VS_SHADOW_RES);
    int texels = vs_shadow_field_int(VS_DATA_ARG(shadow_data) light, VS_SHADOW_TEXELS);
    float bias = vs_shadow_field(VS_DATA_ARG(shadow_data) light, VS_SHADOW_BIAS);
    pnanovdb_vec3_t o = vs_shadow_vec(VS_DATA_ARG(shadow_data) light, VS_SHADOW_ORIGIN);
    pnanovdb_vec3_t d = vs_vec3(p.x - o.x, p.y - o.y, p.z - o.z);
    if (kind == VS_SHADOW_SUN) {
        float half_width = vs_shadow_field(VS_DATA_ARG(shadow_data) light, VS_SHADOW_HALF);
        float x =
            vs_vec3_dot(d, vs_shadow_vec(VS_DATA_ARG(shadow_data) light, VS_SHADOW_U)) / half_width;
        float y =
            vs_vec3_dot(d, vs_shadow_vec(VS_DATA_ARG(shadow_data) light, VS_SHADOW_V)) / half_width;
        float depth = vs_vec3_dot(d, vs_shadow_vec(VS_DATA_ARG(shadow_data) light, VS_SHADOW_W));
        return vs_shadow_pcf(VS_DATA_ARG(shadow_data) texels, res, x, y, depth, bias);
    }
    /* A cube: the face of the major axis. */
    float ax = vs_abs(d.x), ay = vs_abs(d.y), az = vs_abs(d.z);
    int axis = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
    float major = axis == 0 ? d.x : (axis == 1 ? d.y : d.z);
    float b = axis == 0 ? d.y : (axis == 1 ? d.z : d.x);
    float c = axis == 0 ? d.z : (axis == 1 ? d.x : d.y);
    if (!(vs_abs(major) > 0.0f))
        return 1.0f;
    int face = 2 * axis + (major < 0.0f ? 1 : 0);
    float distance = vs_sqrt(vs_vec3_dot(d, d));
    return vs_shadow_pcf(VS_DATA_ARG(shadow_data) texels + face * res * res, res, b / vs_abs(major),
                         c / vs_abs(major), distance, bias);
}

#endif
