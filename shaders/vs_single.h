/* Single scattering per voxel (the exact S1 pass), shared by C and GLSL. Include after
 * vs_common.h, vs_march.h, vs_medium.h and vs_lights.h.
 *
 * Output: the direction average of S1 at a voxel centre, (1/4pi) times the fluence of the
 * unscattered light: sum over suns E T, over points I T / r^2, over sky ordinates
 * L_k w_k T_k, with T the marched transmittance to the light (docs/design.md: a collimated beam
 * of irradiance E attenuated to T has fluence E T, and the HG phase integrates to 1).
 *
 * The work of a voxel is one unit per light: the direct lights in table order, then the
 * sky ordinates. A pass may run any range of units (the GPU runs them in passes, see
 * vs_pass.h); ranges add to the fluence in unit order, so any split sums like one pass. */
#ifndef VS_SINGLE_H
#define VS_SINGLE_H

/* Units of work per voxel: one march per direct light and per sky ordinate. */
VS_FUNC int vs_single_units(VS_DATA_ONLY(vs_vec4, light_data))
{
    return vs_lights_direct_count(VS_DATA_ONLY_ARG(light_data)) +
           vs_lights_ordinate_count(VS_DATA_ONLY_ARG(light_data));
}

/* Adds the fluence of units [first, first + count) to `fluence`. */
VS_FUNC pnanovdb_vec3_t vs_single_accumulate(VS_DATA_PARAM(vs_vec4, medium_data)
                                                 VS_DATA_PARAM(vs_vec4, light_data)
                                                     pnanovdb_buf_t buf,
                                             PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                             pnanovdb_coord_t ijk, pnanovdb_vec3_t fluence,
                                             int first, int count)
{
    int direct = vs_lights_direct_count(VS_DATA_ONLY_ARG(light_data));
    int total = vs_single_units(VS_DATA_ONLY_ARG(light_data));
    float density_scale = vs_medium_density_scale(VS_DATA_ONLY_ARG(medium_data));
    pnanovdb_vec3_t box_lo = vs_medium_box_lo(VS_DATA_ONLY_ARG(medium_data));
    pnanovdb_vec3_t box_hi = vs_medium_box_hi(VS_DATA_ONLY_ARG(medium_data));
    pnanovdb_vec3_t p = vs_vec3(VS_FLOAT(ijk.x), VS_FLOAT(ijk.y), VS_FLOAT(ijk.z));
    /* count may be huge (one pass for everything): compare without overflowing. */
    int last = total - first > count ? first + count : total;

    for (int i = first; i < last; ++i) {
        if (i >= direct) {
            int k = i - direct;
            float transmittance =
                vs_transmittance(buf, acc, p, vs_ordinate_index(VS_DATA_ARG(light_data) k),
                                 VS_T_INFINITE, box_lo, box_hi, density_scale);
            fluence = vs_vec3_madd(fluence, vs_ordinate_weighted(VS_DATA_ARG(light_data) k),
                                   transmittance);
            continue;
        }
        pnanovdb_vec3_t at = vs_light_index(VS_DATA_ARG(light_data) i);
        float weight;
        float transmittance;
        if (vs_light_type(VS_DATA_ARG(light_data) i) == VS_LIGHT_SUN) {
            weight = 1.0f;
            transmittance =
                vs_transmittance(buf, acc, p, at, VS_T_INFINITE, box_lo, box_hi, density_scale);
        } else {
            vs_point_view v =
                vs_point_light_view(VS_DATA_ARG(medium_data) VS_DATA_ARG(light_data) i, p);
            float r = v.distance;
            weight = v.falloff;
            transmittance = r > 0.0f
                                ? vs_transmittance(buf, acc, p, vs_vec3_scale(v.offset, 1.0f / r),
                                                   r, box_lo, box_hi, density_scale)
                                : 1.0f;
        }
        fluence = vs_vec3_madd(fluence, vs_light_color(VS_DATA_ARG(light_data) i),
                               weight * transmittance);
    }
    return fluence;
}

/* The direction average of S1: fluence / 4pi. */
VS_FUNC pnanovdb_vec3_t vs_single_average(VS_DATA_PARAM(vs_vec4, medium_data)
                                              VS_DATA_PARAM(vs_vec4, light_data) pnanovdb_buf_t buf,
                                          PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                          pnanovdb_coord_t ijk)
{
    pnanovdb_vec3_t fluence = vs_single_accumulate(
        VS_DATA_ARG(medium_data) VS_DATA_ARG(light_data) buf, acc, ijk, vs_vec3(0.0f, 0.0f, 0.0f),
        0, vs_single_units(VS_DATA_ONLY_ARG(light_data)));
    return vs_vec3_scale(fluence, VS_INV_4PI);
}

#endif
