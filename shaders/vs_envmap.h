/* The environment map as the render kernels see it (shared by C and GLSL): a float buffer
 * `env_data` with a small header and the lat-long texels (vdbscatter/envmap.h gives the
 * convention), looked up bilinearly between texel centres. Include after vs_common.h. */
#ifndef VS_ENVMAP_H
#define VS_ENVMAP_H

#define VS_ENV_OFF_WIDTH 0  /* texels per row; 0 when there is no map */
#define VS_ENV_OFF_HEIGHT 1 /* rows */
#define VS_ENV_OFF_TEXELS 4 /* RGB floats, row 0 the +Y pole */

/* Radiance arriving from world direction d (any length) off the map; 0 without one. */
VS_FUNC pnanovdb_vec3_t vs_env_radiance(VS_DATA_PARAM(float, env_data) pnanovdb_vec3_t d)
{
    int w = VS_INT(env_data[VS_ENV_OFF_WIDTH]);
    int h = VS_INT(env_data[VS_ENV_OFF_HEIGHT]);
    if (w < 2 || h < 2)
        return vs_vec3(0.0f, 0.0f, 0.0f);
    float r = vs_sqrt(d.x * d.x + d.z * d.z);
    float lat = vs_atan2(d.y, r);
    float lon = r > 0.0f ? vs_atan2(d.x, d.z) : 0.0f;
    float x = (lon / (-2.0f * VS_PI) + 0.5f) * VS_FLOAT(w - 1);
    float y = (lat / -VS_PI + 0.5f) * VS_FLOAT(h - 1);
    x = vs_min(vs_max(x, 0.0f), VS_FLOAT(w - 1));
    y = vs_min(vs_max(y, 0.0f), VS_FLOAT(h - 1));
    int x0 = VS_INT(x), y0 = VS_INT(y);
    int x1 = x0 + 1 < w ? x0 + 1 : x0;
    int y1 = y0 + 1 < h ? y0 + 1 : y0;
    float fx = x - VS_FLOAT(x0), fy = y - VS_FLOAT(y0);
    int t00 = VS_ENV_OFF_TEXELS + 3 * (y0 * w + x0), t10 = VS_ENV_OFF_TEXELS + 3 * (y0 * w + x1);
    int t01 = VS_ENV_OFF_TEXELS + 3 * (y1 * w + x0), t11 = VS_ENV_OFF_TEXELS + 3 * (y1 * w + x1);
    float c[3];
    for (int ch = 0; ch < 3; ++ch) {
        VS_PRECISE float a = env_data[t00 + ch] + fx * (env_data[t10 + ch] - env_data[t00 + ch]);
        VS_PRECISE float b = env_data[t01 + ch] + fx * (env_data[t11 + ch] - env_data[t01 + ch]);
        VS_PRECISE float v = a + fy * (b - a);
        c[ch] = v;
    }
    return vs_vec3(c[0], c[1], c[2]);
}

#endif
