/* Single scattering per voxel (the exact S1 pass), shared by C and GLSL.
 *
 * Output: the direction average of S1 at a voxel centre,
 *   (1/4pi) sum_lights E_i T_i  +  (1/K) sum_k L_sky T_k,
 * with T the transmittance to the light (DESIGN.md: a collimated beam of irradiance E
 * attenuated to T has fluence E T, and the HG phase integrates to 1).
 *
 * light_data layout (vec4 each), written by single.c:
 *   [0] (light count, sky direction count, density_scale, minimum point-light distance)
 *   [1..3] index-to-world linear rows (xyz) for world distances
 *   [4] box_lo (xyz), [5] box_hi (xyz): index-space support of the interpolant
 *   [6] sky radiance already divided by K (rgb)
 *   then per light two entries: (type, x, y, z), (r, g, b, 0) with colour / 4pi;
 *     type 0 = sun, xyz = index-space image of a unit world step towards the sun;
 *     type 1 = point, xyz = index-space position of the light
 *   then K sky directions (index-space image of a unit world step towards the sky).
 */
#ifndef VS_SINGLE_H
#define VS_SINGLE_H

#define VS_SINGLE_HEADER 7
#define VS_LIGHT_SUN 0
#define VS_LIGHT_POINT 1

/* Adds the contributions of marches [first, first + count) to sum, in march order, so that
 * any split of the marches into passes (the GPU needs passes: llvmpipe ends every loop of
 * an invocation after 65535 iterations) sums in the same order as one pass. */
VS_FUNC pnanovdb_vec3_t vs_single_accumulate(VS_DATA_PARAM(vs_vec4, light_data) pnanovdb_buf_t buf,
                                             PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                             pnanovdb_coord_t ijk, pnanovdb_vec3_t sum, int first,
                                             int count)
{
    int light_count = VS_INT(light_data[0].x);
    int total = light_count + VS_INT(light_data[0].y);
    float density_scale = light_data[0].z;
    float r_min = light_data[0].w;
    pnanovdb_vec3_t box_lo = vs_vec3_from_vec4(light_data[4]);
    pnanovdb_vec3_t box_hi = vs_vec3_from_vec4(light_data[5]);
    pnanovdb_vec3_t p = vs_vec3(VS_FLOAT(ijk.x), VS_FLOAT(ijk.y), VS_FLOAT(ijk.z));
    int last = first + count < total ? first + count : total;

    for (int i = first; i < last; ++i) {
        if (i >= light_count) {
            float transmittance = vs_transmittance(
                buf, acc, p, vs_vec3_from_vec4(light_data[VS_SINGLE_HEADER + light_count + i]),
                VS_T_INFINITE, box_lo, box_hi, density_scale);
            sum = vs_vec3_madd(sum, vs_vec3_from_vec4(light_data[6]), transmittance);
            continue;
        }
        vs_vec4 head = light_data[VS_SINGLE_HEADER + 2 * i];
        pnanovdb_vec3_t color = vs_vec3_from_vec4(light_data[VS_SINGLE_HEADER + 2 * i + 1]);
        float weight;
        float transmittance;
        if (VS_INT(head.x) == VS_LIGHT_SUN) {
            weight = 1.0f;
            transmittance = vs_transmittance(buf, acc, p, vs_vec3(head.y, head.z, head.w),
                                             VS_T_INFINITE, box_lo, box_hi, density_scale);
        } else {
            pnanovdb_vec3_t d = vs_vec3(head.y - p.x, head.z - p.y, head.w - p.z);
            pnanovdb_vec3_t w = vs_vec3(vs_vec3_dot(vs_vec3_from_vec4(light_data[1]), d),
                                        vs_vec3_dot(vs_vec3_from_vec4(light_data[2]), d),
                                        vs_vec3_dot(vs_vec3_from_vec4(light_data[3]), d));
            float r = vs_sqrt(vs_vec3_dot(w, w));
            float rc = vs_max(r, r_min);
            weight = 1.0f / (rc * rc);
            transmittance = r > 0.0f ? vs_transmittance(buf, acc, p, vs_vec3_scale(d, 1.0f / r), r,
                                                        box_lo, box_hi, density_scale)
                                     : 1.0f;
        }
        sum = vs_vec3_madd(sum, color, weight * transmittance);
    }
    return sum;
}

VS_FUNC pnanovdb_vec3_t vs_single_average(VS_DATA_PARAM(vs_vec4, light_data) pnanovdb_buf_t buf,
                                          PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                          pnanovdb_coord_t ijk)
{
    return vs_single_accumulate(VS_DATA_ARG(light_data) buf, acc, ijk, vs_vec3(0.0f, 0.0f, 0.0f), 0,
                                VS_INT(light_data[0].x) + VS_INT(light_data[0].y));
}

#endif
