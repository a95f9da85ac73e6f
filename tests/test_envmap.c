/* Lat-long environment maps: OpenEXR's LatLong convention (poles on rows 0 and H-1, both
 * seam columns at longitude +-pi, +Y up), texel solid angles summing to 4 pi, the
 * importance-sampled quadrature (exact for a constant map, the luminance integral exactly
 * for any map), bad maps refused, and bakes lit by maps against their closed-form twins: a
 * constant map against the constant sky, a map whose energy sits in one texel against the
 * sun of the same irradiance, and a marked texel lighting a thin probe from its side. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/envmap.h"
#include "vdbscatter/image.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/render.h"
#include "vdbscatter/single.h"
#include "vdbscatter/scene_file.h"

#define PI 3.14159265358979323846

static int teardown(void **state)
{
    (void)state;
    test_runners_free();
    return 0;
}

/* Writes a W x H EXR map with every texel `value` and returns its path. */
static const char *write_map(const char *name, int w, int h, const float value[3])
{
    vdbs_image image;
    vdbs_error err;
    assert_int_equal(vdbs_image_alloc(&image, w, h, 0, &err), VDBS_OK);
    for (int i = 0; i < w * h; ++i)
        memcpy(image.rgb + 3 * i, value, sizeof(float) * 3);
    const char *path = test_tmp_path(name);
    assert_int_equal(vdbs_image_write(path, &image, 0.0, &err), VDBS_OK);
    vdbs_image_free(&image);
    return path;
}

static void load_ok(const char *path, double scale, vdbs_envmap *map)
{
    vdbs_error err;
    if (vdbs_envmap_load(path, scale, map, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

static void test_convention(void **state)
{
    (void)state;
    const float one[3] = {1.0f, 1.0f, 1.0f};
    vdbs_envmap map;
    load_ok(write_map("env_conv.exr", 64, 32, one), 1.0, &map);
    double d[3];
    /* Row 0 is the +Y pole; the middle of the map looks along +Z; column 0 is longitude +pi
     * (-Z), a quarter of the way across longitude +pi/2 (+X). */
    const struct {
        double x, y, want[3];
    } cases[] = {
        {10.0, 0.0, {0.0, 1.0, 0.0}},
        {10.0, 31.0, {0.0, -1.0, 0.0}},
        {31.5, 15.5, {0.0, 0.0, 1.0}},
        {0.0, 15.5, {0.0, 0.0, -1.0}},
        {63.0, 15.5, {0.0, 0.0, -1.0}},
        {63.0 / 4.0, 15.5, {1.0, 0.0, 0.0}},
        {3 * 63.0 / 4.0, 15.5, {-1.0, 0.0, 0.0}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        vdbs_envmap_direction(&map, cases[i].x, cases[i].y, d);
        for (int a = 0; a < 3; ++a)
            assert_true(fabs(d[a] - cases[i].want[a]) < 1e-12);
    }
    /* Position and direction invert each other away from the seam and the poles. */
    for (double y = 1.0; y < 31.0; y += 1.7)
        for (double x = 1.0; x < 63.0; x += 2.3) {
            double px, py;
            vdbs_envmap_direction(&map, x, y, d);
            vdbs_envmap_position(&map, d, &px, &py);
            assert_true(fabs(px - x) < 1e-9 && fabs(py - y) < 1e-9);
        }
    /* The texels' solid angles tile the sphere. */
    double sum = 0.0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x)
            sum += vdbs_envmap_texel_solid_angle(&map, x, y);
    print_message("64x32 map: texel solid angles sum to 4 pi %+.1e\n", sum - 4.0 * PI);
    assert_true(fabs(sum - 4.0 * PI) < 1e-12);
    vdbs_envmap_free(&map);
}

/* A Radiance .hdr map reads as its OpenEXR twin, to RGBE's 8-bit mantissas (relative to
 * each texel's largest channel). */
static void test_hdr_file(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_image sky;
    assert_int_equal(vdbs_envmap_test_sky(16, &sky, &err), VDBS_OK);
    const char *exr = test_tmp_path("env_sky.exr"), *hdr = test_tmp_path("env_sky.hdr");
    assert_int_equal(vdbs_image_write(exr, &sky, 0.0, &err), VDBS_OK);
    assert_int_equal(vdbs_image_write(hdr, &sky, 0.0, &err), VDBS_OK);
    vdbs_image_free(&sky);
    vdbs_envmap a, b;
    load_ok(exr, 1.0, &a);
    load_ok(hdr, 1.0, &b);
    assert_int_equal(a.width, b.width);
    assert_int_equal(a.height, b.height);
    double worst = 0.0;
    /* RGBE shares one exponent per texel: each channel to 2^-8 of the texel's largest. */
    for (int t = 0; t < a.width * a.height; ++t) {
        const float *p = a.rgb + 3 * t, *q = b.rgb + 3 * t;
        double top = fmax(p[0], fmax(p[1], p[2]));
        for (int c = 0; c < 3; ++c)
            worst = fmax(worst, fabs(p[c] - q[c]) / top);
    }
    print_message("hdr against exr: worst relative difference %.2e\n", worst);
    assert_true(worst < 1.0 / 128.0);
    vdbs_envmap_free(&a);
    vdbs_envmap_free(&b);
}

static void test_sampling(void **state)
{
    (void)state;
    const int K = 256;
    double dirs[3 * 256], weight[256], radiance[3 * 256];
    vdbs_error err;
    /* A constant map: every weight is 4 pi / K, every radiance the constant. */
    const float grey[3] = {0.25f, 0.5f, 0.75f};
    vdbs_envmap map;
    load_ok(write_map("env_const.exr", 64, 32, grey), 2.0, &map);
    assert_int_equal(vdbs_envmap_sample(&map, NULL, K, dirs, weight, radiance, &err), K);
    for (int k = 0; k < K; ++k) {
        assert_true(fabs(weight[k] - 4.0 * PI / K) < 1e-12);
        assert_true(radiance[3 * k + 2] == 1.5);
        double n = sqrt(dirs[3 * k] * dirs[3 * k] + dirs[3 * k + 1] * dirs[3 * k + 1] +
                        dirs[3 * k + 2] * dirs[3 * k + 2]);
        assert_true(fabs(n - 1.0) < 1e-12);
    }
    vdbs_envmap_free(&map);
    /* Any map: sum_k w_k lum(L_k) is the luminance integral exactly; the directions follow
     * the energy (a bright upper half). */
    vdbs_image image;
    assert_int_equal(vdbs_image_alloc(&image, 64, 32, 0, &err), VDBS_OK);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x)
            for (int c = 0; c < 3; ++c)
                image.rgb[3 * (y * 64 + x) + c] =
                    (float)((y < 16 ? 10.0 : 0.5) * (1.0 + 0.5 * sin(0.3 * x + c)));
    const char *path = test_tmp_path("env_var.exr");
    assert_int_equal(vdbs_image_write(path, &image, 0.0, &err), VDBS_OK);
    vdbs_image_free(&image);
    load_ok(path, 1.0, &map);
    double integral = 0.0, estimate = 0.0, upper = 0.0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x) {
            const float *t = map.rgb + 3 * (y * 64 + x);
            integral += (0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2]) *
                        vdbs_envmap_texel_solid_angle(&map, x, y);
        }
    assert_int_equal(vdbs_envmap_sample(&map, NULL, K, dirs, weight, radiance, &err), K);
    for (int k = 0; k < K; ++k) {
        const double *L = radiance + 3 * k;
        estimate += weight[k] * (0.2126 * L[0] + 0.7152 * L[1] + 0.0722 * L[2]);
        upper += dirs[3 * k + 1] > 0.0;
    }
    print_message("luminance integral %.9g, K = %d estimate %.9g; %.0f of %d directions up\n",
                  integral, K, estimate, upper, K);
    assert_true(fabs(estimate / integral - 1.0) < 1e-9);
    assert_true(upper > 0.9 * K); /* 95% of the energy is above the horizon */
    vdbs_envmap_free(&map);
}

static void bad_map(const char *path, double scale, const char *needle)
{
    vdbs_envmap map;
    vdbs_error err;
    assert_int_equal(vdbs_envmap_load(path, scale, &map, &err), VDBS_ERR_INPUT);
    print_message("refused: %s\n", err.message);
    assert_non_null(strstr(err.message, needle));
    assert_null(map.rgb);
}

static void test_bad_maps(void **state)
{
    (void)state;
    const float one[3] = {1.0f, 1.0f, 1.0f};
    bad_map(write_map("env_square.exr", 32, 32, one), 1.0, "twice as wide");
    const float negative[3] = {1.0f, -1.0f, 1.0f};
    bad_map(write_map("env_negative.exr", 16, 8, negative), 1.0, "negative");
    const float nan[3] = {1.0f, NAN, 1.0f};
    bad_map(write_map("env_nan.exr", 16, 8, nan), 1.0, "not finite");
    bad_map(write_map("env_scale.exr", 16, 8, one), -1.0, "scale");
    bad_map(test_tmp_path("env_missing.exr"), 1.0, "env_missing.exr");
    bad_map(write_map("env_png.png", 16, 8, one), 1.0, "not an OpenEXR or Radiance HDR");
    FILE *f = fopen(test_tmp_path("env_text.hdr"), "w");
    fputs("#?RADIANCE\nnot really\n", f);
    fclose(f);
    bad_map(test_tmp_path("env_text.hdr"), 1.0, "env_text.hdr");
}

/* S1 radiance of a scene from light grids with K sky ordinates. */
static float *bake(const vdbs_volume *volume, const vdbs_scene *scene, int sky)
{
    float *radiance = calloc(3 * volume->coord_count, sizeof(float));
    vdbs_error err;
    vdbs_lights_desc ld = {.sky_ordinates = sky};
    vdbs_light_table lights;
    if (vdbs_lights_build(volume, scene, &ld, &lights, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_single_scatter_grids(test_runner(VDBS_BACKEND_CPU), volume, scene, &lights, NULL,
                                  radiance, NULL, NULL, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_lights_free(&lights);
    return radiance;
}

static double relrmse(const float *a, const float *b, size_t n)
{
    double peak = 0.0, num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; ++i)
        peak = fmax(peak, b[i]);
    for (size_t i = 0; i < n; ++i)
        if (b[i] > 1e-3 * peak) {
            num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
            den += (double)b[i] * b[i];
        }
    return sqrt(num / den);
}

static void env_scene(vdbs_scene *scene, const char *map, double scale)
{
    vdbs_error err;
    vdbs_scene_init(scene);
    scene->density_scale = 12.0;
    scene->light_count = 1;
    vdbs_light *l = &scene->lights[0];
    l->type = VDBS_LIGHT_ENV;
    l->color[0] = l->color[1] = l->color[2] = 1.0;
    l->env_scale = scale;
    assert_int_equal(vdbs_light_set_env_file(scene, l, map, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(scene, &err), VDBS_OK);
}

/* A constant-colour map bakes as the constant sky (K = 256); a map whose energy sits in one
 * texel bakes as a sun of the same irradiance travelling away from that texel. */
static void test_bake_twins(void **state)
{
    (void)state;
    vdbs_volume volume;
    test_sample_volume("cloud", 32, 3, &volume);
    const size_t n = 3 * volume.coord_count;
    vdbs_error err;

    const float sky[3] = {0.2f, 0.3f, 0.5f};
    vdbs_scene with_map, constant;
    env_scene(&with_map, write_map("env_sky.exr", 128, 64, sky), 1.0);
    vdbs_scene_init(&constant);
    constant.density_scale = 12.0;
    constant.light_count = 1;
    constant.lights[0].type = VDBS_LIGHT_ENV;
    memcpy(constant.lights[0].color, (double[3]){0.2, 0.3, 0.5}, sizeof(double) * 3);
    assert_int_equal(vdbs_scene_validate(&constant, &err), VDBS_OK);
    float *a = bake(&volume, &with_map, 256), *b = bake(&volume, &constant, 256);
    double e = relrmse(a, b, n);
    print_message("constant map against the constant sky, K 256: relative RMSE %.2e\n", e);
    assert_true(e <= 0.01);
    free(a);
    free(b);

    /* One bright texel of a 512 x 256 map (0.7 degrees wide). */
    const int w = 512, h = 256, tx = 300, ty = 70;
    vdbs_image image;
    assert_int_equal(vdbs_image_alloc(&image, w, h, 0, &err), VDBS_OK);
    memset(image.rgb, 0, sizeof(float) * 3 * w * h);
    const float L[3] = {5000.0f, 4000.0f, 3000.0f};
    memcpy(image.rgb + 3 * (ty * w + tx), L, sizeof L);
    const char *path = test_tmp_path("env_texel.exr");
    assert_int_equal(vdbs_image_write(path, &image, 0.0, &err), VDBS_OK);
    vdbs_image_free(&image);
    vdbs_envmap map;
    load_ok(path, 1.0, &map);
    double omega = vdbs_envmap_texel_solid_angle(&map, tx, ty), from[3];
    vdbs_envmap_direction(&map, tx, ty, from);
    vdbs_envmap_free(&map);
    vdbs_scene texel, sun;
    env_scene(&texel, path, 1.0);
    vdbs_scene_init(&sun);
    sun.density_scale = 12.0;
    sun.light_count = 1;
    sun.lights[0].type = VDBS_LIGHT_SUN;
    for (int c = 0; c < 3; ++c) {
        sun.lights[0].direction[c] = -from[c];
        sun.lights[0].color[c] = L[c] * omega;
    }
    assert_int_equal(vdbs_scene_validate(&sun, &err), VDBS_OK);
    a = bake(&volume, &texel, 16);
    b = bake(&volume, &sun, 16);
    e = relrmse(a, b, n);
    print_message("one-texel map against the sun of its irradiance: relative RMSE %.2e\n", e);
    assert_true(e <= 0.01);
    free(a);
    free(b);
    vdbs_volume_free(&volume);
}

/* A thin slab across x, lit by a map bright only around longitude +pi/2, latitude 0 (the +X
 * direction): the light arrives from +X, so the slab's +X face is the bright one; the same
 * bright spot moved to longitude -pi/2 lights the -X face. */
static void test_probe_side(void **state)
{
    (void)state;
    const int dims[3] = {4, 12, 12};
    float *values = malloc(sizeof(float) * 4 * 12 * 12);
    for (int i = 0; i < 4 * 12 * 12; ++i)
        values[i] = 1.0f;
    const int origin[3] = {0, 0, 0};
    vdbio_transform xf = {{{0.1, 0, 0, 0}, {0, 0.1, 0, 0}, {0, 0, 0.1, 0}}};
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_density_from_dense(values, dims, origin, &xf, "density", &density, &err),
                     VDBS_OK);
    free(values);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    const int w = 64, h = 32;
    for (int side = 0; side < 2; ++side) {
        vdbs_image image;
        assert_int_equal(vdbs_image_alloc(&image, w, h, 0, &err), VDBS_OK);
        memset(image.rgb, 0, sizeof(float) * 3 * w * h);
        /* Longitude +pi/2 is x = (W-1)/4, -pi/2 is 3 (W-1)/4; latitude 0 is y = (H-1)/2. */
        int x0 = side == 0 ? 15 : 47;
        for (int y = 15; y <= 16; ++y)
            for (int x = x0; x <= x0 + 1; ++x)
                for (int c = 0; c < 3; ++c)
                    image.rgb[3 * (y * w + x) + c] = 100.0f;
        const char *path = test_tmp_path(side == 0 ? "env_east.exr" : "env_west.exr");
        assert_int_equal(vdbs_image_write(path, &image, 0.0, &err), VDBS_OK);
        vdbs_image_free(&image);
        vdbs_scene scene;
        env_scene(&scene, path, 1.0);
        scene.density_scale = 10.0;
        float *r = bake(&volume, &scene, 16);
        double lo = 0.0, hi = 0.0;
        for (size_t v = 0; v < volume.coord_count; ++v) {
            const int32_t *c = volume.coords + 3 * v;
            if (c[1] >= 4 && c[1] <= 7 && c[2] >= 4 && c[2] <= 7) {
                if (c[0] == 0)
                    lo += r[3 * v];
                if (c[0] == 3)
                    hi += r[3 * v];
            }
        }
        print_message("spot at longitude %s pi/2: -X face %.4g, +X face %.4g\n",
                      side == 0 ? "+" : "-", lo, hi);
        assert_true(side == 0 ? hi > 1.5 * lo : lo > 1.5 * hi);
        free(r);
    }
    vdbs_volume_free(&volume);
}

/* Bilinear between texel centres at the map position of dir, in double (the oracle). */
static void bilinear(const vdbs_envmap *map, const double dir[3], double rgb[3])
{
    double x, y;
    vdbs_envmap_position(map, dir, &x, &y);
    x = fmin(fmax(x, 0.0), map->width - 1.0);
    y = fmin(fmax(y, 0.0), map->height - 1.0);
    int x0 = (int)x, y0 = (int)y;
    int x1 = x0 + 1 < map->width ? x0 + 1 : x0, y1 = y0 + 1 < map->height ? y0 + 1 : y0;
    double fx = x - x0, fy = y - y0;
    for (int c = 0; c < 3; ++c) {
        const float *p = map->rgb + c;
        double a = p[3 * (y0 * map->width + x0)], b = p[3 * (y0 * map->width + x1)];
        double d = p[3 * (y1 * map->width + x0)], e = p[3 * (y1 * map->width + x1)];
        rgb[c] = (a + fx * (b - a)) * (1.0 - fy) + (d + fx * (e - d)) * fy;
    }
}

/* Rays that leave the volume see the map: with an empty medium every pixel of the render is
 * the map looked up along its camera ray (the kernel's float lookup against a double
 * bilinear of the texels). */
static void test_background(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_image sky;
    assert_int_equal(vdbs_envmap_test_sky(32, &sky, &err), VDBS_OK);
    const char *path = test_tmp_path("env_background.exr");
    assert_int_equal(vdbs_image_write(path, &sky, 0.0, &err), VDBS_OK);
    vdbs_image_free(&sky);
    vdbs_volume volume;
    test_sample_volume("cloud", 16, 3, &volume);
    vdbs_scene scene;
    env_scene(&scene, path, 2.0);
    scene.density_scale = 0.0;
    vdbs_envmap map;
    load_ok(path, 2.0, &map);
    vdbs_camera camera = {1, {0.3, 0.2, 2.0}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, 120.0, 24, 16};
    vdbs_camera_frame frame;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_image image;
    assert_int_equal(vdbs_image_alloc(&image, 24, 16, 0, &err), VDBS_OK);
    vdbs_march_options options = {0};
    options.sky_directions = 16;
    options.step_voxels = 1.0f;
    assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &volume, NULL, &scene, &frame,
                                       &options, &image, &err),
                     VDBS_OK);
    double worst = 0.0;
    for (int py = 0; py < 16; ++py)
        for (int px = 0; px < 24; ++px) {
            double dir[3], want[3];
            vdbs_camera_ray(&frame, px + 0.5, py + 0.5, dir);
            bilinear(&map, dir, want);
            for (int c = 0; c < 3; ++c)
                worst = fmax(worst, test_rel_diff(image.rgb[3 * (py * 24 + px) + c], want[c]));
        }
    print_message("background against the map along the camera rays: worst relative "
                  "difference %.2e\n",
                  worst);
    assert_true(worst <= 1e-5);
    vdbs_image_free(&image);
    vdbs_envmap_free(&map);
    vdbs_volume_free(&volume);
}

/* The sun of the test sky (vdbs_envmap_test_sky: 3000 in red on a disc of 1.5 degrees radius at
 * longitude 30, latitude 35 degrees) is found as one compact region: its direction within a
 * texel (2.8 degrees at 128 x 64) of the true one, its red power within 2x of 3000 times the
 * disc's solid angle (the disc covers one or two texel centres), and the sampling weight zeroed
 * on it; POP's light table then has the sun as ordinate 0 carrying that power and no other
 * ordinate on it. A constant map has no sun. */
static void test_sun_split(void **state)
{
    (void)state;
    vdbs_image sky;
    vdbs_error err;
    assert_int_equal(vdbs_envmap_test_sky(64, &sky, &err), VDBS_OK);
    const char *path = test_tmp_path("env_sun.exr");
    assert_int_equal(vdbs_image_write(path, &sky, 0.0, &err), VDBS_OK);
    vdbs_image_free(&sky);
    vdbs_envmap map;
    load_ok(path, 1.0, &map);
    const size_t texels = (size_t)map.width * map.height;
    float *w = malloc(sizeof(float) * texels);
    for (size_t i = 0; i < texels; ++i)
        w[i] = 1.0f;
    double dir[3], power[3], omega = 0.0;
    assert_int_equal(vdbs_envmap_find_sun(&map, w, dir, power, &omega), 1);
    const double lat = 35.0 * PI / 180.0, lon = 30.0 * PI / 180.0;
    const double sun[3] = {sin(lon) * cos(lat), sin(lat), cos(lon) * cos(lat)};
    const double angle = acos(fmin(1.0, dir[0] * sun[0] + dir[1] * sun[1] + dir[2] * sun[2]));
    const double disc = 2.0 * PI * (1.0 - cos(1.5 * PI / 180.0));
    int zeroed = 0;
    for (size_t i = 0; i < texels; ++i)
        zeroed += w[i] == 0.0f;
    print_message("sun found %.2f degrees off, %d texels, %.5f sr, red power %.3f (disc: %.3f)\n",
                  angle * 180.0 / PI, zeroed, omega, power[0], 3000.0 * disc);
    assert_true(angle < 2.8 * PI / 180.0);
    assert_true(zeroed >= 1 && omega < VDBS_ENVMAP_SUN_MAX_OMEGA);
    assert_true(power[0] > 0.5 * 3000.0 * disc && power[0] < 2.0 * 3000.0 * disc);
    free(w);

    vdbs_scene scene;
    vdbs_scene_init(&scene);
    vdbs_light *env = &scene.lights[scene.light_count++];
    memset(env, 0, sizeof *env);
    env->type = VDBS_LIGHT_ENV;
    env->env_scale = 1.0;
    assert_int_equal(vdbs_light_set_env_file(&scene, env, path, &err), VDBS_OK);
    vdbs_volume volume;
    test_sample_volume("sphere", 16, 1, &volume);
    vdbs_lights_desc ld = {.sky_ordinates = 8, .split_sun = 1};
    vdbs_light_table lights;
    assert_int_equal(vdbs_lights_build(&volume, &scene, &ld, &lights, &err), VDBS_OK);
    assert_int_equal(lights.ordinate_count, 8);
    const vdbs_sky_ordinate *o = lights.ordinates;
    assert_true(fabs(o[0].radiance[0] * o[0].weight - power[0]) < 1e-9 * power[0]);
    for (int k = 1; k < 8; ++k) {
        double c = o[k].world[0] * dir[0] + o[k].world[1] * dir[1] + o[k].world[2] * dir[2];
        assert_true(c < cos(2.8 * PI / 180.0));
    }
    vdbs_lights_free(&lights);
    vdbs_volume_free(&volume);
    vdbs_envmap_free(&map);

    const float grey[3] = {0.25f, 0.5f, 0.75f};
    load_ok(write_map("env_flat.exr", 64, 32, grey), 1.0, &map);
    float one = 1.0f, *flat = malloc(sizeof(float) * 64 * 32);
    for (int i = 0; i < 64 * 32; ++i)
        flat[i] = one;
    assert_int_equal(vdbs_envmap_find_sun(&map, flat, dir, power, &omega), 0);
    for (int i = 0; i < 64 * 32; ++i)
        assert_true(flat[i] == 1.0f);
    free(flat);
    vdbs_envmap_free(&map);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_convention), cmocka_unit_test(test_hdr_file),
        cmocka_unit_test(test_sampling),   cmocka_unit_test(test_bad_maps),
        cmocka_unit_test(test_bake_twins), cmocka_unit_test(test_probe_side),
        cmocka_unit_test(test_background), cmocka_unit_test(test_sun_split),
    };
    return cmocka_run_group_tests(tests, NULL, teardown);
}
