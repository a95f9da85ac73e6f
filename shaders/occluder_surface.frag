#version 450
/* The viewer's solid occluders seen from the camera: a Lambertian surface lit by the suns
 * and point lights of the light table (vs_lights.h) through the occluders' shadow maps
 * (vs_shadow.h), by the constant sky, and by the homogeneous fog's indirect single
 * scattering of point lights (vs_fog.h, Biri Sec. III.C), the direct light dimmed by the
 * volume (its light grids, vs_lightgrid.h: the cloud's shadow on the floor) and by the fog
 * along its path. Writes (distance from the camera, radiance): the render kernel's backdrop. */
#define PNANOVDB_GLSL
layout(std430, binding = 0) readonly buffer NanoBuffer { uint pnanovdb_buf_data[]; };
layout(std430, binding = 1) readonly buffer MediumBuffer { vec4 medium_data[]; };
layout(std430, binding = 2) readonly buffer LightBuffer { vec4 light_data[]; };
layout(std430, binding = 3) readonly buffer ShadowBuffer { float shadow_data[]; };
layout(std430, binding = 4) readonly buffer FogBuffer { float fog_data[]; };
layout(std430, binding = 5) readonly buffer LightGridBuffer { uint lgrid_data[]; };

#include "PNanoVDB.h"
#include "vs_common.h"
#include "vs_phase.h"
#include "vs_medium.h"
#include "vs_march.h"
#include "vs_lights.h"
#include "vs_lightgrid.h"
#include "vs_shadow.h"
#include "vs_fog.h"

in vec3 world_position;
in vec3 world_normal;
out vec4 result;

uniform vec3 camera;
uniform vec3 albedo;
uniform int with_fog;
uniform vec3 fog_lo;
uniform vec3 fog_hi;
uniform vec3 fog_albedo;
uniform int with_light_grids;
uniform vec4 to_index[3]; /* the volume's world-to-index map, rows */

/* Distance from p to the fog box's boundary along u, 0 outside the box. A surface on a
 * face of the box (a floor under the fog) counts as inside, whatever the rounding. */
float fog_path(vec3 p, vec3 u)
{
    vec3 q = clamp(p, fog_lo, fog_hi);
    if (distance(p, q) > 1e-4 * distance(fog_lo, fog_hi))
        return 0.0;
    return max(0.0, vs_box_exit(q, u, fog_lo, fog_hi));
}

void main()
{
    vec3 p = world_position;
    vec3 n = normalize(world_normal);
    /* Seen from behind (a plane from below): the side the camera sees. */
    if (dot(n, camera - p) < 0.0)
        n = -n;
    float sigma_t = with_fog != 0 ? vs_fog_sigma_t() : 0.0;
    vec4 pw = vec4(p, 1.0);
    vec3 p_index = vec3(dot(to_index[0], pw), dot(to_index[1], pw), dot(to_index[2], pw));
    vec3 L = albedo * vs_lights_background();
    int lights = vs_lights_direct_count();
    for (int k = 0; k < lights; ++k) {
        vec3 colour = vs_light_color(k);
        vec3 world = vs_light_world(k);
        vec3 to_light;
        float irradiance_scale;
        float fog_t = 1.0;
        if (vs_light_type(k) == VS_LIGHT_SUN) {
            to_light = -world;
            irradiance_scale = 1.0;
            if (with_fog != 0)
                fog_t = exp(-sigma_t * fog_path(p, to_light));
        } else {
            vec3 d = world - p;
            float r = max(length(d), 1e-6);
            to_light = d / r;
            irradiance_scale = 1.0 / (r * r);
            if (with_fog != 0) {
                fog_t = exp(-sigma_t * r);
                L += fog_albedo * colour *
                     vs_fog_surface_indirect(r, dot(n, to_light), 1.0, 1.0) * albedo;
            }
        }
        float cosine = max(dot(n, to_light), 0.0);
        /* Beyond the grid the lookup clamps to its edge: below the cloud, the whole column. */
        float volume_t = with_light_grids != 0 ? exp(-vs_lgrid_depth(k, p_index)) : 1.0;
        if (cosine > 0.0)
            L += albedo * (1.0 / VS_PI) * colour * (irradiance_scale * cosine * fog_t * volume_t *
                                               vs_shadow_visibility(k, p));
    }
    result = vec4(length(p - camera), L);
}
