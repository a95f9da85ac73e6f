/* The viewer's homogeneous fog over a picture, shared by C and GLSL: per pixel, the fog's
 * single scattering of every sun and point light along the view ray inside the fog box, up
 * to the first solid surface (the backdrop), in closed form (vs_fog.h, Biri's Eq. 7 over lit
 * spans, Eq. 14), and the fog's transmittance over the picture behind it:
 *   L = L_fog + exp(-sigma_t (s_end - s_enter)) L_picture.
 * The shadowed parts of the ray are found by stepping the occluders' shadow maps
 * (vs_shadow.h) at `steps` points; a run of fully lit steps is one span (one Gamma
 * difference), a partly lit step (the maps' filtered edge) counts its lit fraction. With
 * interleaved sampling each pixel's steps start at its own phase (k + 0.5) / M^2 of a step,
 * and the gather pass (vs_gather.h) averages the M x M block, as in vs_render.h.
 * Approximations, written down in docs/viewer.md: the fog is composited in front of the
 * picture (the volume's extinction does not dim the fog, nor the fog the volume's lights),
 * and the volume does not shadow the fog. Include after vs_common.h, vs_march.h, vs_phase.h,
 * vs_lights.h, vs_shadow.h and vs_fog.h. */
#ifndef VS_FOGPASS_H
#define VS_FOGPASS_H

/* The pass table (vec4 rows). */
#define VS_FOGPASS_OFF_ORIGIN 0  /* camera world position, image width */
#define VS_FOGPASS_OFF_FORWARD 1 /* camera forward (world), image height */
#define VS_FOGPASS_OFF_RIGHT 2   /* right * tan(half fov x), 0 */
#define VS_FOGPASS_OFF_UP 3      /* up * tan(half fov y), 0 */
#define VS_FOGPASS_OFF_BOX_LO 4  /* fog box, steps along a ray */
#define VS_FOGPASS_OFF_BOX_HI 5  /* fog box, interleave block M (1: off) */
#define VS_FOGPASS_OFF_ALBEDO                                                                      \
    6 /* fog albedo rgb (the fog table's albedo is 1), 1 with a backdrop */
#define VS_FOGPASS_SIZE 7

/* One light's in-scattering over [s0, s1] (colour and albedo applied by the caller). */
VS_FUNC float vs_fogpass_span(VS_DATA_PARAM(vs_vec4, light_data)
                                  VS_DATA_PARAM(float, fog_data) int light,
                              pnanovdb_vec3_t o, pnanovdb_vec3_t d, pnanovdb_vec3_t lo,
                              pnanovdb_vec3_t hi, float s_enter, float s0, float s1)
{
    pnanovdb_vec3_t world = vs_light_world(VS_DATA_ARG(light_data) light);
    if (vs_light_type(VS_DATA_ARG(light_data) light) == VS_LIGHT_SUN)
        return vs_fog_sun_span(VS_DATA_ARG(fog_data) o, d, world, 1.0f, lo, hi, s_enter, s0, s1);
    return vs_fog_point_span(VS_DATA_ARG(fog_data) o, d, world, 1.0f, s_enter, s0, s1);
}

/* The fogged radiance of pixel (px, py) over its picture value `behind`. */
VS_FUNC pnanovdb_vec3_t vs_fogpass_pixel(VS_DATA_PARAM(vs_vec4, pass_data) VS_DATA_PARAM(vs_vec4,
                                                                                         light_data)
                                             VS_DATA_PARAM(float, fog_data)
                                                 VS_DATA_PARAM(float, shadow_data)
                                                     VS_DATA_PARAM(vs_vec4, backdrop_data) int px,
                                         int py, pnanovdb_vec3_t behind)
{
    float width = pass_data[VS_FOGPASS_OFF_ORIGIN].w;
    pnanovdb_vec3_t d =
        vs_pinhole_direction(pass_data[VS_FOGPASS_OFF_FORWARD], pass_data[VS_FOGPASS_OFF_RIGHT],
                             pass_data[VS_FOGPASS_OFF_UP], width, px, py);
    pnanovdb_vec3_t o = vs_vec3_from_vec4(pass_data[VS_FOGPASS_OFF_ORIGIN]);
    pnanovdb_vec3_t lo = vs_vec3_from_vec4(pass_data[VS_FOGPASS_OFF_BOX_LO]);
    pnanovdb_vec3_t hi = vs_vec3_from_vec4(pass_data[VS_FOGPASS_OFF_BOX_HI]);
    float s_enter = vs_box_enter(o, d, lo, hi);
    float s_end = vs_box_exit(o, d, lo, hi);
    if (pass_data[VS_FOGPASS_OFF_ALBEDO].w != 0.0f)
        s_end = vs_min(s_end, backdrop_data[py * VS_INT(width) + px].x);
    if (!(s_end > s_enter))
        return behind;
    float sigma_t = vs_fog_sigma_t(VS_DATA_ONLY_ARG(fog_data));
    float fog_t = vs_exp(-sigma_t * (s_end - s_enter));
    int steps = VS_INT(pass_data[VS_FOGPASS_OFF_BOX_LO].w);
    int m = VS_INT(pass_data[VS_FOGPASS_OFF_BOX_HI].w);
    float phase = 0.5f;
    if (m > 1)
        phase = (VS_FLOAT(px % m + m * (py % m)) + 0.5f) / VS_FLOAT(m * m);
    float step = (s_end - s_enter) / VS_FLOAT(steps);
    pnanovdb_vec3_t sum = vs_vec3(0.0f, 0.0f, 0.0f);
    int lights = vs_lights_direct_count(VS_DATA_ONLY_ARG(light_data));
    for (int light = 0; light < lights; ++light) {
        /* Runs of lit steps become one span; [run_start, s) is the open run. */
        float lit = 0.0f;
        float run_start = s_enter;
        int in_run = 0;
        for (int k = 0; k < steps; ++k) {
            float a = s_enter + VS_FLOAT(k) * step;
            float b = k + 1 == steps ? s_end : a + step;
            float v = vs_shadow_visibility(VS_DATA_ARG(shadow_data) light,
                                           vs_vec3_madd(o, d, a + phase * (b - a)));
            if (v >= 1.0f) {
                if (in_run == 0)
                    run_start = a;
                in_run = 1;
                continue;
            }
            if (in_run != 0)
                lit += vs_fogpass_span(VS_DATA_ARG(light_data) VS_DATA_ARG(fog_data) light, o, d,
                                       lo, hi, s_enter, run_start, a);
            in_run = 0;
            if (v > 0.0f)
                lit += v * vs_fogpass_span(VS_DATA_ARG(light_data) VS_DATA_ARG(fog_data) light, o,
                                           d, lo, hi, s_enter, a, b);
        }
        if (in_run != 0)
            lit += vs_fogpass_span(VS_DATA_ARG(light_data) VS_DATA_ARG(fog_data) light, o, d, lo,
                                   hi, s_enter, run_start, s_end);
        sum = vs_vec3_madd(sum, vs_light_color(VS_DATA_ARG(light_data) light), lit);
    }
    pnanovdb_vec3_t albedo = vs_vec3_from_vec4(pass_data[VS_FOGPASS_OFF_ALBEDO]);
    return vs_vec3(albedo.x * sum.x + fog_t * behind.x, albedo.y * sum.y + fog_t * behind.y,
                   albedo.z * sum.z + fog_t * behind.z);
}

#endif
