#include "vdbscatter/envmap.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/image.h"

#include "io/exrmap.h"
#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_envmap.h"

vdbs_status vdbs_envmap_load(const char *path, double scale, vdbs_envmap *map, vdbs_error *err)
{
    memset(map, 0, sizeof *map);
    if (!(scale >= 0.0) || !isfinite(scale))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: env scale %g is not a finite value >= 0",
                              path, scale);
    vdbs_image_kind kind;
    vdbs_status st = vdbs_image_kind_of(path, &kind, err);
    if (st != VDBS_OK)
        return st;
    if (kind != VDBS_IMAGE_EXR && kind != VDBS_IMAGE_HDR)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: not an OpenEXR or Radiance HDR environment map", path);
    /* EXR maps go through Imf (exrmap.cpp: every channel type, layout and codec); Radiance
     * HDR through the image reader. */
    vdbs_image image;
    st = kind == VDBS_IMAGE_EXR ? vdbs_exrmap_read(path, &image, err)
                                : vdbs_image_read(path, &image, err);
    if (st != VDBS_OK)
        return st;
    if (image.width != 2 * image.height || image.height < 2) {
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "%s: a lat-long map is twice as wide as high, this one is %dx%d", path,
                            image.width, image.height);
        vdbs_image_free(&image);
        return st;
    }
    const size_t n = 3 * (size_t)image.width * (size_t)image.height;
    for (size_t i = 0; i < n; ++i)
        if (!(image.rgb[i] >= 0.0f) || !isfinite(image.rgb[i])) {
            size_t texel = i / 3;
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "%s: texel (%zu, %zu) is %g (negative or not "
                                "finite)",
                                path, texel % (size_t)image.width, texel / (size_t)image.width,
                                (double)image.rgb[i]);
            vdbs_image_free(&image);
            return st;
        }
    map->bytes = sizeof(float) * (VS_ENV_OFF_TEXELS + n);
    map->data = calloc(1, map->bytes);
    if (!map->data) {
        vdbs_image_free(&image);
        memset(map, 0, sizeof *map);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory for the map", path);
    }
    map->width = image.width;
    map->height = image.height;
    map->data[VS_ENV_OFF_WIDTH] = (float)image.width;
    map->data[VS_ENV_OFF_HEIGHT] = (float)image.height;
    map->rgb = map->data + VS_ENV_OFF_TEXELS;
    for (size_t i = 0; i < n; ++i)
        map->rgb[i] = (float)(image.rgb[i] * scale);
    vdbs_image_free(&image);
    return VDBS_OK;
}

void vdbs_envmap_free(vdbs_envmap *map)
{
    if (!map)
        return;
    free(map->data);
    memset(map, 0, sizeof *map);
}

static double latitude_of(const vdbs_envmap *m, double y)
{
    return -VDBS_PI * (y / (m->height - 1) - 0.5);
}

static double longitude_of(const vdbs_envmap *m, double x)
{
    return -2.0 * VDBS_PI * (x / (m->width - 1) - 0.5);
}

void vdbs_envmap_direction(const vdbs_envmap *map, double x, double y, double dir[3])
{
    double lat = latitude_of(map, y), lon = longitude_of(map, x);
    dir[0] = sin(lon) * cos(lat);
    dir[1] = sin(lat);
    dir[2] = cos(lon) * cos(lat);
}

void vdbs_envmap_position(const vdbs_envmap *map, const double dir[3], double *x, double *y)
{
    double r = sqrt(dir[0] * dir[0] + dir[2] * dir[2]);
    double len = sqrt(r * r + dir[1] * dir[1]);
    double lat = len > 0.0 ? atan2(dir[1], r) : 0.0;
    double lon = r > 0.0 ? atan2(dir[0], dir[2]) : 0.0;
    *x = (lon / (-2.0 * VDBS_PI) + 0.5) * (map->width - 1);
    *y = (lat / -VDBS_PI + 0.5) * (map->height - 1);
}

/* Longitude and sin(latitude) ranges of texel (x, y). */
static void texel_bounds(const vdbs_envmap *m, int x, int y, double *lon0, double *lon1, double *s0,
                         double *s1)
{
    double dlon = 2.0 * VDBS_PI / (m->width - 1), dlat = VDBS_PI / (m->height - 1);
    double lon = longitude_of(m, x), lat = latitude_of(m, y);
    *lon0 = fmax(lon - 0.5 * dlon, -VDBS_PI);
    *lon1 = fmin(lon + 0.5 * dlon, VDBS_PI);
    *s0 = sin(fmax(lat - 0.5 * dlat, -0.5 * VDBS_PI));
    *s1 = sin(fmin(lat + 0.5 * dlat, 0.5 * VDBS_PI));
}

double vdbs_envmap_texel_solid_angle(const vdbs_envmap *map, int x, int y)
{
    double lon0, lon1, s0, s1;
    texel_bounds(map, x, y, &lon0, &lon1, &s0, &s1);
    return (lon1 - lon0) * (s1 - s0);
}

void vdbs_envmap_lookup(const vdbs_envmap *map, const double dir[3], double rgb[3])
{
    pnanovdb_vec3_t v =
        vs_env_radiance(map->data, vs_vec3((float)dir[0], (float)dir[1], (float)dir[2]));
    rgb[0] = v.x;
    rgb[1] = v.y;
    rgb[2] = v.z;
}

static double luminance(const float *rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/* The first index i with cdf[i + 1] > u (cdf[0] = 0, cdf[n] = 1, non-decreasing). */
static int cdf_find(const double *cdf, int n, double u)
{
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (cdf[mid + 1] > u)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

static double radical_inverse2(uint32_t k)
{
    k = (k << 16) | (k >> 16);
    k = ((k & 0x00ff00ffu) << 8) | ((k & 0xff00ff00u) >> 8);
    k = ((k & 0x0f0f0f0fu) << 4) | ((k & 0xf0f0f0f0u) >> 4);
    k = ((k & 0x33333333u) << 2) | ((k & 0xccccccccu) >> 2);
    k = ((k & 0x55555555u) << 1) | ((k & 0xaaaaaaaau) >> 1);
    return k * (1.0 / 4294967296.0);
}

vdbs_status vdbs_envmap_sampler_init(const vdbs_envmap *map, vdbs_envmap_sampler *s,
                                     vdbs_error *err)
{
    return vdbs_envmap_sampler_init_weighted(map, NULL, s, err);
}

/* The density of texel (x, y) before normalisation: luminance times the texel's weight. */
static double texel_density(const vdbs_envmap_sampler *s, const float *texel, size_t at)
{
    return luminance(texel) * (s->texel_weight ? s->texel_weight[at] : 1.0f);
}

vdbs_status vdbs_envmap_sampler_init_weighted(const vdbs_envmap *map, const float *texel_weight,
                                              vdbs_envmap_sampler *s, vdbs_error *err)
{
    memset(s, 0, sizeof *s);
    const int w = map->width, h = map->height;
    s->map = map;
    s->texel_weight = texel_weight;
    s->row_cdf = malloc(sizeof *s->row_cdf * (size_t)h * (size_t)(w + 1));
    s->marginal = malloc(sizeof *s->marginal * (size_t)(h + 1));
    if (!s->row_cdf || !s->marginal) {
        vdbs_envmap_sampler_free(s);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for an env map's CDF");
    }
    s->marginal[0] = 0.0;
    for (int y = 0; y < h; ++y) {
        double *c = s->row_cdf + (size_t)y * (w + 1);
        c[0] = 0.0;
        for (int x = 0; x < w; ++x)
            c[x + 1] =
                c[x] + texel_density(s, map->rgb + 3 * ((size_t)y * w + x), (size_t)y * w + x) *
                           vdbs_envmap_texel_solid_angle(map, x, y);
        double row = c[w];
        for (int x = 1; x <= w; ++x)
            c[x] = row > 0.0 ? c[x] / row : (double)x / w;
        s->marginal[y + 1] = s->marginal[y] + row;
    }
    s->total = s->marginal[h];
    for (int y = 1; y <= h && s->total > 0.0; ++y)
        s->marginal[y] /= s->total;
    return VDBS_OK;
}

void vdbs_envmap_sampler_free(vdbs_envmap_sampler *s)
{
    free(s->row_cdf);
    free(s->marginal);
    memset(s, 0, sizeof *s);
}

double vdbs_envmap_sampler_draw(const vdbs_envmap_sampler *s, double u1, double u2, double dir[3],
                                double radiance[3])
{
    const vdbs_envmap *map = s->map;
    const int w = map->width, h = map->height;
    int y = cdf_find(s->marginal, h, u1);
    const double *c = s->row_cdf + (size_t)y * (w + 1);
    int x = cdf_find(c, w, u2);
    /* Where u fell inside the texel's share: uniform in solid angle over the texel. */
    double fy = (u1 - s->marginal[y]) / fmax(s->marginal[y + 1] - s->marginal[y], 1e-300);
    double fx = (u2 - c[x]) / fmax(c[x + 1] - c[x], 1e-300);
    fy = fmin(fmax(fy, 0.0), 1.0);
    fx = fmin(fmax(fx, 0.0), 1.0);
    double lon0, lon1, s0, s1;
    texel_bounds(map, x, y, &lon0, &lon1, &s0, &s1);
    double lon = lon0 + fx * (lon1 - lon0);
    double sl = s1 + fy * (s0 - s1); /* rows run from +Y down */
    double cl = sqrt(fmax(0.0, 1.0 - sl * sl));
    dir[0] = sin(lon) * cl;
    dir[1] = sl;
    dir[2] = cos(lon) * cl;
    const float *texel = map->rgb + 3 * ((size_t)y * w + x);
    for (int ch = 0; ch < 3; ++ch)
        radiance[ch] = texel[ch];
    return texel_density(s, texel, (size_t)y * w + x) / s->total;
}

/* The texel whose solid angle holds dir (texel_bounds: halfway to the neighbours). */
static const float *texel_of(const vdbs_envmap *map, const double dir[3])
{
    double x, y;
    vdbs_envmap_position(map, dir, &x, &y);
    int xi = (int)floor(x + 0.5), yi = (int)floor(y + 0.5);
    xi = xi < 0 ? 0 : (xi >= map->width ? map->width - 1 : xi);
    yi = yi < 0 ? 0 : (yi >= map->height ? map->height - 1 : yi);
    return map->rgb + 3 * ((size_t)yi * map->width + xi);
}

void vdbs_envmap_texel(const vdbs_envmap *map, const double dir[3], double rgb[3])
{
    const float *t = texel_of(map, dir);
    for (int c = 0; c < 3; ++c)
        rgb[c] = t[c];
}

double vdbs_envmap_sampler_pdf(const vdbs_envmap_sampler *s, const double dir[3])
{
    const float *texel = texel_of(s->map, dir);
    return s->total > 0.0 ? texel_density(s, texel, (size_t)(texel - s->map->rgb) / 3) / s->total
                          : 0.0;
}

int vdbs_envmap_sample(const vdbs_envmap *map, const float *texel_weight, int count, double *dirs,
                       double *weight, double *radiance, vdbs_error *err)
{
    vdbs_envmap_sampler s;
    if (vdbs_envmap_sampler_init_weighted(map, texel_weight, &s, err) != VDBS_OK)
        return -1;
    int written = 0;
    for (int k = 0; k < count && s.total > 0.0; ++k) {
        double pdf = vdbs_envmap_sampler_draw(&s, (k + 0.5) / count, radical_inverse2((uint32_t)k),
                                              dirs + 3 * written, radiance + 3 * written);
        weight[written++] = 1.0 / (count * pdf);
    }
    vdbs_envmap_sampler_free(&s);
    return written;
}

vdbs_status vdbs_envmap_test_sky(int height, vdbs_image *image, vdbs_error *err)
{
    if (height < 2 || height > 8192)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "sky: height %d is not in 2..8192", height);
    vdbs_status st = vdbs_image_alloc(image, 2 * height, height, 0, err);
    if (st != VDBS_OK)
        return st;
    vdbs_envmap map = {0};
    map.width = 2 * height;
    map.height = height; /* only the geometry is read */
    const double lat = 35.0 * VDBS_PI / 180.0, lon = 30.0 * VDBS_PI / 180.0;
    const double sun[3] = {sin(lon) * cos(lat), sin(lat), cos(lon) * cos(lat)};
    const double zenith[3] = {0.15, 0.3, 0.7}, horizon[3] = {0.7, 0.8, 0.9};
    const double ground[3] = {0.12, 0.1, 0.08}, sun_rgb[3] = {3000.0, 2800.0, 2500.0};
    const double cos_disc = cos(1.5 * VDBS_PI / 180.0);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < 2 * height; ++x) {
            double d[3];
            vdbs_envmap_direction(&map, x, y, d);
            double c = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
            double glow = 2.0 * exp(-(1.0 - c) * 40.0);
            float *p = image->rgb + 3 * ((size_t)y * 2 * height + x);
            for (int ch = 0; ch < 3; ++ch) {
                double v = d[1] >= 0.0 ? horizon[ch] + (zenith[ch] - horizon[ch]) * sqrt(d[1])
                                       : ground[ch];
                v += glow * horizon[ch];
                if (c >= cos_disc)
                    v = sun_rgb[ch];
                p[ch] = (float)v;
            }
        }
    return VDBS_OK;
}

int vdbs_envmap_find_sun(const vdbs_envmap *map, float *texel_weight, double dir[3],
                         double power[3], double *omega)
{
    const int w = map->width, h = map->height;
    double mean = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            mean += luminance(map->rgb + 3 * ((size_t)y * w + x)) *
                    vdbs_envmap_texel_solid_angle(map, x, y);
    mean /= 4.0 * VDBS_PI;
    double d[3] = {0.0, 0.0, 0.0}, p[3] = {0.0, 0.0, 0.0}, area = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float *t = map->rgb + 3 * ((size_t)y * w + x);
            if (!(luminance(t) > VDBS_ENVMAP_SUN_CONTRAST * mean))
                continue;
            double o = vdbs_envmap_texel_solid_angle(map, x, y), td[3];
            vdbs_envmap_direction(map, x, y, td);
            for (int c = 0; c < 3; ++c) {
                p[c] += t[c] * o;
                d[c] += luminance(t) * o * td[c];
            }
            area += o;
        }
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(area > 0.0) || area > VDBS_ENVMAP_SUN_MAX_OMEGA || !(len > 0.0))
        return 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            if (luminance(map->rgb + 3 * ((size_t)y * w + x)) > VDBS_ENVMAP_SUN_CONTRAST * mean)
                texel_weight[(size_t)y * w + x] = 0.0f;
    for (int c = 0; c < 3; ++c) {
        dir[c] = d[c] / len;
        power[c] = p[c];
    }
    *omega = area;
    return 1;
}
