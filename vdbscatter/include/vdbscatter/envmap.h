/* Lat-long environment maps (docs/design.md "Environment maps"): OpenEXR or Radiance HDR files in
 * OpenEXR's Imf::LatLong layout (ImfEnvmap.cpp), +Y up. Pixel (x, y) of a W x H map looks
 * along latitude -pi (y / (H - 1) - 1/2) and longitude -2 pi (x / (W - 1) - 1/2), direction
 * (sin lon cos lat, sin lat, cos lon cos lat): rows 0 and H - 1 sit on the poles, columns 0
 * and W - 1 both on longitude +-pi. A texel holds the radiance arriving *from* its direction.
 *
 * Texel solid angles: texel (x, y) covers the longitudes and latitudes halfway to its
 * neighbours, clamped to [-pi, pi] and [-pi/2, pi/2], so the first and last column and row
 * cover half a step and the solid angles sum to 4 pi.
 *
 * Sampling: texels are drawn with probability proportional to luminance times solid angle
 * and a point inside the texel uniformly in solid angle, from a deterministic stratified
 * (Hammersley) set through the 2D CDF, so a bake is reproducible. Each of the K directions
 * carries the texel's radiance and the weight 1 / (K pdf) in steradians: sum_k L_k w_k T_k
 * is a consistent quadrature of integral L T over the sphere (exact for a constant map, where
 * every w_k = 4 pi / K). */
#ifndef VDBSCATTER_ENVMAP_H
#define VDBSCATTER_ENVMAP_H

#include <stddef.h>

#include "vdbscatter/image.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_envmap {
    int width, height;
    float *data;  /* the kernels' layout (shaders/vs_envmap.h): a header, then the texels */
    size_t bytes; /* of data */
    float *rgb;   /* data's texels: 3 * width * height, radiance times the scale, row 0 the
                     +Y pole */
} vdbs_envmap;

/* Reads `path` (OpenEXR or Radiance HDR) and multiplies it by scale. An OpenEXR map is its
 * data window's R, G, B (or Y as grey) in any channel type, tiling and compression
 * (docs/envmap.md). Errors (VDBS_ERR_INPUT, one line naming the file): missing, unreadable,
 * truncated, another format, no usable channels, a width not twice the height, negative or
 * non-finite texels, a scale that is negative or not finite. */
vdbs_status vdbs_envmap_load(const char *path, double scale, vdbs_envmap *map, vdbs_error *err);
void vdbs_envmap_free(vdbs_envmap *map);

/* The direction of (continuous) pixel position (x, y), and back (x in [0, W-1], y in
 * [0, H-1]). */
void vdbs_envmap_direction(const vdbs_envmap *map, double x, double y, double dir[3]);
void vdbs_envmap_position(const vdbs_envmap *map, const double dir[3], double *x, double *y);

/* Solid angle of texel (x, y) in steradians. */
double vdbs_envmap_texel_solid_angle(const vdbs_envmap *map, int x, int y);

/* Radiance arriving from `dir` (any length), bilinear between texel centres: what rays that
 * leave the volume see (the kernels' lookup, vs_envmap.h). */
void vdbs_envmap_lookup(const vdbs_envmap *map, const double dir[3], double rgb[3]);

/* The radiance of the texel whose solid angle holds `dir`: the map as lighting, piecewise
 * constant over the texels, which is what the sampling below integrates exactly (its pdf is
 * positive on every texel with light, so the quadrature and the reference's next-event
 * estimates converge to the same integral). */
void vdbs_envmap_texel(const vdbs_envmap *map, const double dir[3], double rgb[3]);

/* The luminance x solid angle distribution of a map (the map must outlive it). */
typedef struct vdbs_envmap_sampler {
    const vdbs_envmap *map;
    double *row_cdf;           /* height rows of width + 1 */
    double *marginal;          /* height + 1 */
    double total;              /* integral of luminance over the sphere; 0 for a black map */
    const float *texel_weight; /* per texel factor on the luminance, or NULL */
} vdbs_envmap_sampler;

vdbs_status vdbs_envmap_sampler_init(const vdbs_envmap *map, vdbs_envmap_sampler *sampler,
                                     vdbs_error *err);
/* The same for luminance times texel_weight[y width + x] (>= 0; NULL: 1): the sky times an
 * importance (pop.h --pop-importance). The weights must outlive the sampler. */
vdbs_status vdbs_envmap_sampler_init_weighted(const vdbs_envmap *map, const float *texel_weight,
                                              vdbs_envmap_sampler *sampler, vdbs_error *err);
void vdbs_envmap_sampler_free(vdbs_envmap_sampler *sampler);
/* A direction for (u1, u2) in [0, 1)^2 (towards the sky), the texel's radiance, and its pdf
 * per steradian (returned; total must be > 0). */
double vdbs_envmap_sampler_draw(const vdbs_envmap_sampler *sampler, double u1, double u2,
                                double dir[3], double radiance[3]);
/* The pdf per steradian of drawing `dir`: the luminance of its texel over total. */
double vdbs_envmap_sampler_pdf(const vdbs_envmap_sampler *sampler, const double dir[3]);

/* K importance-sampled directions (see above; from luminance times texel_weight when that is
 * not NULL): dirs 3 K (unit, towards the sky), weight K (steradians: 1 / (K pdf)), radiance
 * 3 K. Returns the number written: K, or 0 for a black map; -1 when out of memory. */
int vdbs_envmap_sample(const vdbs_envmap *map, const float *texel_weight, int count, double *dirs,
                       double *weight, double *radiance, vdbs_error *err);

/* A sun in the map: the texels brighter than VDBS_ENVMAP_SUN_CONTRAST times the map's mean
 * luminance, when they cover at most VDBS_ENVMAP_SUN_MAX_OMEGA sr. Returns 1 and gives their
 * luminance-weighted mean direction (towards the sky), their power (sum of radiance x solid
 * angle per channel) and solid angle, and sets texel_weight (width x height) to 0 on them;
 * returns 0 and changes nothing when the map has no such compact bright region. */
#define VDBS_ENVMAP_SUN_CONTRAST 64.0
#define VDBS_ENVMAP_SUN_MAX_OMEGA 0.05
int vdbs_envmap_find_sun(const vdbs_envmap *map, float *texel_weight, double dir[3],
                         double power[3], double *omega);
/* The test sky (`vdbscatter sample sky`): a 2 height x height lat-long image (allocated
 * here) of a blue sky brightening to the horizon, a dim ground and a small sun (about 3
 * degrees, 20 000 times the zenith) at longitude 30 and latitude 35 degrees with a glow. */
vdbs_status vdbs_envmap_test_sky(int height, vdbs_image *image, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
