/* Closed-form checks of the ray-march renderer's C path (the kernel text of
 * shaders/vs_render.h and shaders/vs_phase.h): the HG phase function, 1 - exp(-x), the Sms
 * reconstruction from ms / ms_l1 grids, an empty medium, single scattering in a
 * homogeneous slab, and baked mode of a single-scattering bake against single mode. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/sphere.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/camera.h"
#include "vdbscatter/fog.h"
#include "vdbscatter/march_session.h"
#include "vdbscatter/render.h"
#include "vdbscatter/shadow.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/single.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_phase.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_lightgrid.h"
#include "vs_envmap.h"
#include "vs_shadow.h"
#include "vs_render.h"

#define PI 3.14159265358979323846

static double hg_naive(double g, double mu)
{
    return (1.0 - g * g) / (4.0 * PI * pow(1.0 + g * g - 2.0 * g * mu, 1.5));
}

/* The kernel's HG for unit directions at polar angle theta from wo = +Z, and the naive form
 * in double for the same float vectors (accurate in double: the cancellation in
 * 1 + g^2 - 2 g mu costs at most 10 of its 16 digits). */
static float hg_at(float g, double theta, double *naive)
{
    pnanovdb_vec3_t wo = vs_vec3(0.0f, 0.0f, 1.0f);
    pnanovdb_vec3_t wi = vs_vec3((float)sin(theta), 0.0f, (float)cos(theta));
    if (naive) {
        double x = wi.x, z = wi.z;
        /* mu by the kernel's definition: 1 - |wi-wo|^2/2, or |wi+wo|^2/2 - 1 for g < 0. */
        double mu = g >= 0.0f ? 1.0 - 0.5 * (x * x + (z - 1.0) * (z - 1.0))
                              : 0.5 * (x * x + (z + 1.0) * (z + 1.0)) - 1.0;
        *naive = hg_naive(g, mu);
    }
    return vs_hg_dirs(g, wi, wo);
}

/* Integral of p over the sphere, 2 pi int_0^pi p sin(theta) d theta, by 8-point
 * Gauss-Legendre on intervals that shrink geometrically (20 per decade, down to 1e-6 rad)
 * towards both poles, where the peaks of |g| -> 1 sit (width ~ 1 - |g| rad). */
static double hg_integral(float g)
{
    static const double node[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                   0.9602898564975363};
    static const double weight[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                     0.1012285362903763};
    double edges[512];
    int n = 0;
    edges[n++] = 0.0;
    for (int k = 120; k >= 1; --k)
        edges[n++] = pow(10.0, -k / 20.0); /* 1e-6 .. 0.89 */
    for (int k = 0; k <= 20; ++k)
        edges[n++] = 1.0 + (PI - 2.0) * k / 20.0;
    for (int k = 1; k <= 120; ++k)
        edges[n++] = PI - pow(10.0, -k / 20.0);
    edges[n++] = PI;
    double sum = 0.0;
    for (int i = 0; i + 1 < n; ++i) {
        double c = 0.5 * (edges[i] + edges[i + 1]), h = 0.5 * (edges[i + 1] - edges[i]);
        for (int j = 0; j < 4; ++j)
            for (int side = -1; side <= 1; side += 2) {
                double theta = c + side * h * node[j];
                sum += h * weight[j] * hg_at(g, theta, NULL) * sin(theta);
            }
    }
    return 2.0 * PI * sum;
}

static void test_hg(void **state)
{
    (void)state;
    const float gs[] = {0.0f, 0.5f, -0.5f, -0.9f, 0.9f, 0.99f, -0.99f, 0.999f, -0.999f};
    for (size_t i = 0; i < sizeof gs / sizeof gs[0]; ++i) {
        float g = gs[i];
        double integral = hg_integral(g);
        double worst = 0.0;
        /* Pointwise: from the poles out, where the peaks are, to the equator. */
        for (int k = 0; k <= 400; ++k) {
            double t = k == 0 ? 0.0 : pow(10.0, -7.0 + 7.0 * (k % 200) / 200.0) * (PI / 2.0);
            double theta = k < 200 ? t : PI - t, naive;
            float p = hg_at(g, theta, &naive);
            assert_true(isfinite(p) && p > 0.0f);
            worst = fmax(worst, test_rel_diff(p, naive));
        }
        print_message("g = %6.3f: integral over the sphere - 1 = %9.2e, worst relative "
                      "difference to the naive form in double %.1e\n",
                      g, integral - 1.0, worst);
        assert_true(fabs(integral - 1.0) < 1e-5);
        assert_true(worst < 1e-5);
    }
    assert_true(vs_hg(0.0f, 0.3f) == (float)(1.0 / (4.0 * PI)));
    assert_true(test_rel_diff(vs_hg(-0.5f, 0.5f), hg_naive(-0.5, 0.5)) < 1e-6);
    /* Why the cancellation-free form: the naive form in float is far off at the peak. */
    float g = 0.999f, mu = 1.0f;
    float naive = (1.0f - g * g) / (4.0f * (float)PI * powf(1.0f + g * g - 2.0f * g * mu, 1.5f));
    double exact = hg_naive(g, 1.0);
    print_message("g = 0.999 at mu = 1: naive float off by %.1f%%, vs_hg by %.1e\n",
                  100.0 * test_rel_diff(naive, exact), test_rel_diff(vs_hg(g, 0.0f), exact));
    assert_true(test_rel_diff(vs_hg(g, 0.0f), exact) < 1e-6);
}

static void test_one_minus_exp(void **state)
{
    (void)state;
    double worst = 0.0;
    for (int k = 0; k <= 4000; ++k) {
        double x = pow(10.0, -9.0 + k * 11.0 / 4000.0); /* 1e-9 .. 100 */
        float v = vs_one_minus_exp_neg((float)x);
        double want = -expm1(-(double)(float)x);
        worst = fmax(worst, test_rel_diff(v, want));
    }
    print_message("1 - exp(-x): worst relative error %.2e over [1e-9, 100]\n", worst);
    assert_true(worst < 1e-6);
    assert_true(vs_one_minus_exp_neg(0.0f) == 0.0f);
}

/* Writes a lit VDB over the dense block `dims` (identity transform, density 1) with the
 * same ms and ms_l1 values in every voxel. */
static void write_constant_lit(const char *path, const float ms[3], const float l1[3][3],
                               vdbs_volume *volume)
{
    const int dims[3] = {6, 6, 6};
    float values[216];
    for (int i = 0; i < 216; ++i)
        values[i] = 1.0f;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_density_from_dense(values, dims, NULL, NULL, NULL, &density, &err),
                     VDBS_OK);
    assert_int_equal(vdbs_volume_from_density(density, volume, &err), VDBS_OK);
    size_t n = volume->coord_count;
    float *grid[4];
    for (int g = 0; g < 4; ++g) {
        grid[g] = malloc(3 * n * sizeof(float));
        for (size_t v = 0; v < n; ++v)
            for (int c = 0; c < 3; ++c)
                grid[g][3 * v + c] = g == 0 ? ms[c] : l1[g - 1][c];
    }
    test_write_lit(path, volume, grid[0], grid + 1);
    for (int g = 0; g < 4; ++g)
        free(grid[g]);
}

static double hg_lobe(double b, const double n[3], const double wo[3])
{
    return hg_naive(b, n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2]);
}

static void test_ms_reconstruction(void **state)
{
    (void)state;
    /* Per channel: red isotropic (l1 = 0), green b = 0.5 and blue b = 0.9 about a slanted
     * axis (the clamp at 0.999 is checked on the channel function below). */
    const float ms[3] = {0.3f, 0.2f, 0.1f};
    const double axis[3] = {0.48, -0.6, 0.64};
    const double bs[3] = {0.0, 0.5, 0.9};
    float l1[3][3];
    for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c)
            l1[a][c] = (float)(3.0 * ms[c] * bs[c] * axis[a]);
    vdbs_volume volume;
    const char *path = test_tmp_path("render_constant_lit.vdb");
    write_constant_lit(path, ms, l1, &volume);
    vdbs_error err;
    vdbs_lit_grids grids;
    test_load_ms_grids(path, volume.index_to_world, &grids);

    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.light_count = 1;
    scene.lights[0].type = VDBS_LIGHT_SUN;
    scene.lights[0].direction[1] = -1.0;
    vdbs_camera camera;
    vdbs_camera_frame frame;
    vdbs_camera_frame_volume(&volume, 4, 4, &camera);
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_march_options options = {0};
    options.sky_directions = 4;
    options.step_voxels = 1.0f;
    float *table = NULL;
    size_t entries = 0;
    uint32_t *buffer = NULL;
    size_t size = 0;
    int owned = 0;
    assert_int_equal(vdbs_render_table(&volume, &grids, &frame, &options, &table, &entries, &err),
                     VDBS_OK);
    assert_int_equal(vdbs_render_buffer(&volume, &grids, &buffer, &size, &owned, &err), VDBS_OK);
    assert_true(owned);
    const vs_vec4 *render_data = (const vs_vec4 *)table;
    pnanovdb_buf_t buf = pnanovdb_make_buf(buffer, size / 4);
    vs_render_accessors accs = vs_render_accessors_init(render_data, buf);

    /* Pointwise: at an interior point between voxel centres, for many directions. */
    const int count = 200000;
    double *dirs = malloc(3 * sizeof(double) * count);
    vdbs_sphere_directions(count, dirs);
    double integral[3] = {0.0, 0.0, 0.0}, worst = 0.0;
    pnanovdb_vec3_t p = vs_vec3(2.3f, 2.7f, 3.1f);
    for (int k = 0; k < count; ++k) {
        const double *w = dirs + 3 * k;
        pnanovdb_vec3_t s =
            vs_render_ms(buf, &accs, p, vs_vec3((float)w[0], (float)w[1], (float)w[2]));
        const float got[3] = {s.x, s.y, s.z};
        for (int c = 0; c < 3; ++c) {
            double want = 4.0 * PI * ms[c] * hg_lobe(bs[c], axis, w);
            worst = fmax(worst, test_rel_diff(got[c], want));
            integral[c] += got[c] * 4.0 * PI / count;
        }
    }
    print_message("Sms: worst relative difference to 4 pi ms f_hg(wo.n, b) %.2e; integral / "
                  "(4 pi ms) - 1 = %.1e %.1e %.1e\n",
                  worst, integral[0] / (4.0 * PI * ms[0]) - 1.0,
                  integral[1] / (4.0 * PI * ms[1]) - 1.0, integral[2] / (4.0 * PI * ms[2]) - 1.0);
    /* float grids and float HG against double: a few ulps. */
    assert_true(worst < 1e-5);
    /* The quadrature (200000 equal-weight directions) resolves a b = 0.9 lobe (width ~0.1
     * rad, peak 190 times its mean) to about 1e-5. */
    for (int c = 0; c < 3; ++c)
        assert_true(fabs(integral[c] / (4.0 * PI * ms[c]) - 1.0) < 1e-4);

    /* The channel function itself: clamping, zero and negative ms. */
    pnanovdb_vec3_t wo = vs_vec3(0.48f, -0.6f, 0.64f);
    float big = vs_ms_channel(1.0f, 30.0f * 0.48f, -30.0f * 0.6f, 30.0f * 0.64f, wo);
    assert_true(test_rel_diff(big, 4.0 * PI * hg_naive((double)0.999f, 1.0)) < 1e-4);
    assert_true(vs_ms_channel(0.0f, 1.0f, 0.0f, 0.0f, wo) == 0.0f);
    assert_true(vs_ms_channel(-1.0f, 1.0f, 0.0f, 0.0f, wo) == 0.0f);
    assert_true(vs_ms_channel(0.25f, 0.0f, 0.0f, 0.0f, wo) == 0.25f);
    assert_true(isfinite(vs_ms_channel(1e-30f, 1e30f, 1e30f, 0.0f, wo)));

    free(dirs);
    free(buffer);
    free(table);
    vdbs_lit_grids_free(&grids);
    vdbs_volume_free(&volume);
}

static void image_init(vdbs_image *image, int width, int height)
{
    memset(image, 0, sizeof *image);
    image->width = width;
    image->height = height;
    image->rgb = calloc(3 * (size_t)width * height, sizeof(float));
    assert_non_null(image->rgb);
}

/* A sun straight down (5 W/m^2) and a constant sky (0.2, 0.3, 0.7) over `volume`, and the
 * frame of a 16 x 12 view of it. */
static void sun_and_sky(const vdbs_volume *volume, double density_scale, vdbs_scene *scene,
                        vdbs_camera_frame *frame)
{
    vdbs_error err;
    vdbs_scene_init(scene);
    scene->density_scale = density_scale;
    scene->light_count = 2;
    scene->lights[0].type = VDBS_LIGHT_SUN;
    scene->lights[0].direction[1] = -1.0;
    scene->lights[0].color[0] = scene->lights[0].color[1] = scene->lights[0].color[2] = 5.0;
    scene->lights[1].type = VDBS_LIGHT_ENV;
    scene->lights[1].color[0] = 0.2;
    scene->lights[1].color[1] = 0.3;
    scene->lights[1].color[2] = 0.7;
    assert_int_equal(vdbs_scene_validate(scene, &err), VDBS_OK);
    vdbs_camera camera;
    vdbs_camera_frame_volume(volume, 16, 12, &camera);
    assert_int_equal(vdbs_camera_frame_init(&camera, frame, &err), VDBS_OK);
}

static void test_empty_medium_shows_env(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("cloud", 16, 1, &density, &err), VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    vdbs_scene scene;
    vdbs_camera_frame frame;
    sun_and_sky(&volume, 0.0, &scene, &frame);
    vdbs_image image;
    image_init(&image, 16, 12);
    vdbs_march_options options = {0};
    options.sky_directions = 16;
    options.step_voxels = 0.5f;
    assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &volume, NULL, &scene, &frame,
                                       &options, &image, &err),
                     VDBS_OK);
    for (int i = 0; i < 16 * 12; ++i)
        for (int c = 0; c < 3; ++c)
            assert_true(image.rgb[3 * i + c] == (float)scene.lights[1].color[c]);
    /* Without an env light the background is black. */
    scene.light_count = 1;
    scene.density_scale = 3.0;
    assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &volume, NULL, &scene, &frame,
                                       &options, &image, &err),
                     VDBS_OK);
    for (int c = 0; c < 3; ++c)
        assert_true(image.rgb[c] == 0.0f); /* a corner ray misses the volume */
    free(image.rgb);
    vdbs_volume_free(&volume);
}

/* A camera straight above the slab sample (|y| <= 0.25, density 1, laterally uniform)
 * looking down, and a sun shining straight down: the sun's and the camera's paths to a
 * point coincide, so with tau(z) the optical depth from the top,
 *   L = int sigma_s E exp(-tau) p(-1) exp(-tau) dz = a E p(-1) int_0^tau_total exp(-2 tau)
 *     d tau = a E p(-1) (1 - exp(-2 tau_total)) / 2,
 * whatever the vertical profile (the trilinear ramps at the faces included). The midpoint
 * rule per segment of depth D errs by the factor 1 / cosh(D / 2) ~ 1 - D^2 / 8. */
static void test_slab_closed_form(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_error err;
    const int res = 32;
    assert_int_equal(vdbs_sample_create("slab", res, 0, &density, &err), VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    const double sigma = 4.0, albedo = 0.7, irradiance = 2.0;
    const double tau = sigma * 0.5; /* plateau 0.4375 plus two ramps of half a voxel each */
    const float gs[2] = {0.0f, 0.5f};
    for (int gi = 0; gi < 2; ++gi) {
        vdbs_scene scene;
        vdbs_scene_init(&scene);
        scene.density_scale = sigma;
        scene.albedo[0] = scene.albedo[1] = scene.albedo[2] = albedo;
        scene.g = gs[gi];
        scene.light_count = 1;
        scene.lights[0].type = VDBS_LIGHT_SUN;
        scene.lights[0].direction[1] = -1.0;
        scene.lights[0].color[0] = scene.lights[0].color[1] = scene.lights[0].color[2] = irradiance;
        assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
        vdbs_camera camera = {1, {0.0, 3.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, -1.0}, 10.0, 1, 1};
        vdbs_camera_frame frame;
        assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
        double want = albedo * irradiance * hg_naive(gs[gi], -1.0) * (1.0 - exp(-2.0 * tau)) / 2.0;
        double previous = 1.0;
        for (int q = 0; q < 4; ++q) {
            float step = 1.0f / (float)(1 << q);
            /* The light marches (the oracle); the light grids below. */
            vdbs_march_options options = {0};
            options.sky_directions = 16;
            options.step_voxels = step;
            options.s1_march = 1;
            vdbs_image image;
            image_init(&image, 1, 1);
            assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &volume, NULL, &scene,
                                               &frame, &options, &image, &err),
                             VDBS_OK);
            double rel = fabs(image.rgb[0] - want) / want;
            double d = sigma * step * (2.0 / res); /* optical depth of a full segment */
            print_message("g %.1f step %.3f voxel: L %.9g, closed form %.9g, relative error "
                          "%.2e (bound D^2/8 = %.2e)\n",
                          gs[gi], step, image.rgb[0], want, rel, d * d / 8.0);
            assert_true(image.rgb[0] == image.rgb[1] && image.rgb[1] == image.rgb[2]);
            assert_true(rel <= d * d / 8.0 + 1e-6);
            assert_true(rel < previous); /* converges as the step falls */
            previous = rel;
            free(image.rgb);
        }
        assert_true(previous < 2e-4);
        /* Light grids at the finest step: depth interpolated linearly between samples h =
         * half a voxel apart along the sun. In the ramps the depth is quadratic, tau'' =
         * sigma / voxel, so interpolation errs by at most tau'' h^2 / 8 in depth, and the
         * radiance by at most that relative. */
        vdbs_march_options options = {0};
        options.sky_directions = 16;
        options.step_voxels = 0.125f;
        vdbs_image image;
        image_init(&image, 1, 1);
        assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &volume, NULL, &scene,
                                           &frame, &options, &image, &err),
                         VDBS_OK);
        double rel = fabs(image.rgb[0] - want) / want;
        double voxel = 2.0 / res, h = voxel / 2.0, bound = sigma / voxel * h * h / 8.0;
        print_message("g %.1f, light grids, step 0.125 voxel: relative error %.2e (bound %.2e)\n",
                      gs[gi], rel, bound);
        assert_true(rel <= bound);
        free(image.rgb);
    }
    vdbs_volume_free(&volume);
}

/* Baked mode of a `--method single` bake (ms grids all zero) equals single mode of the
 * bake's input (the acceptance bound is 1e-3 relative RMSE). */
static void test_baked_single_bake_equals_single(void **state)
{
    (void)state;
    vdbs_scene scene;
    vdbs_error err;
    vdbs_scene_init(&scene);
    scene.density_scale = 20.0;
    scene.albedo[0] = scene.albedo[1] = scene.albedo[2] = 0.9;
    scene.g = 0.6;
    scene.light_count = 2;
    scene.lights[0].type = VDBS_LIGHT_SUN;
    scene.lights[0].direction[0] = 0.3;
    scene.lights[0].direction[1] = -1.0;
    scene.lights[0].color[0] = scene.lights[0].color[1] = scene.lights[0].color[2] = 3.0;
    scene.lights[1].type = VDBS_LIGHT_ENV;
    scene.lights[1].color[0] = 0.2;
    scene.lights[1].color[1] = 0.3;
    scene.lights[1].color[2] = 0.5;
    strcpy(scene.quality, "low");
    strcpy(scene.method, "single");
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);

    const char *input = VDBS_TEST_SAMPLES_DIR "/cloud.vdb";
    const char *lit_path = test_tmp_path("render_single_bake.vdb");
    vdbs_bake_options bake = {0};
    bake.input = input;
    bake.output = lit_path;
    bake.scene = &scene;
    bake.backend = VDBS_BACKEND_CPU;
    vdbs_bake_report report;
    if (vdbs_bake(&bake, &report, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    /* The scene recorded in the lit VDB names the volume baked (this scene names none). */
    vdbio_lit *lit = NULL;
    assert_int_equal(vdbio_lit_open(lit_path, &lit, &err), VDBS_OK);
    const char *recorded = vdbio_lit_meta(lit, "vdbscatter_scene");
    assert_non_null(recorded);
    assert_non_null(strstr(recorded, input));
    vdbio_lit_close(lit);

    vdbio_read_options read = {0};
    vdbs_volume source, baked;
    assert_int_equal(vdbs_volume_load(input, &read, &source, &err), VDBS_OK);
    read.grid_name = "density";
    assert_int_equal(vdbs_volume_load(lit_path, &read, &baked, &err), VDBS_OK);
    vdbs_lit_grids grids;
    test_load_ms_grids(lit_path, baked.index_to_world, &grids);

    const int w = 32, h = 24;
    vdbs_camera camera;
    vdbs_camera_frame frame;
    vdbs_camera_frame_volume(&source, w, h, &camera);
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_march_options options = {0};
    assert_true(vdbs_render_quality("low", &options));
    vdbs_image a, b;
    image_init(&a, w, h);
    image_init(&b, w, h);
    assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &source, NULL, &scene, &frame,
                                       &options, &a, &err),
                     VDBS_OK);
    assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &baked, &grids, &scene,
                                       &frame, &options, &b, &err),
                     VDBS_OK);
    double num = 0.0, den = 0.0;
    for (int i = 0; i < 3 * w * h; ++i) {
        num += (double)(b.rgb[i] - a.rgb[i]) * (b.rgb[i] - a.rgb[i]);
        den += (double)a.rgb[i] * a.rgb[i];
    }
    double relrmse = sqrt(num / den);
    print_message("baked (single bake) vs single: relative RMSE %.3g\n", relrmse);
    assert_true(den > 0.0);
    assert_true(relrmse <= 1e-3);
    free(a.rgb);
    free(b.rgb);
    vdbs_lit_grids_free(&grids);
    vdbs_volume_free(&baked);
    vdbs_volume_free(&source);
}

/* The viewer's session: a shadow map that hides the sun everywhere equals a sun of zero
 * irradiance, one without occluders changes nothing, and a backdrop at distance 0 shows
 * the surface's colour alone. */
static void test_session_occluders(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_volume volume;
    test_sample_volume("cloud", 16, 1, &volume);
    vdbs_scene scene;
    vdbs_camera_frame frame;
    sun_and_sky(&volume, 6.0, &scene, &frame);
    vdbs_march_options options = {0};
    options.sky_directions = 16;
    options.step_voxels = 0.5f;
    vdbs_runner *runner = test_runner(VDBS_BACKEND_CPU);
    vdbs_image plain, dark, shot;
    image_init(&plain, 16, 12);
    image_init(&dark, 16, 12);
    image_init(&shot, 16, 12);
    vdbs_march_session *session = NULL;
    assert_int_equal(
        vdbs_march_session_create(runner, &volume, NULL, &scene, &options, &session, &err),
        VDBS_OK);
    assert_int_equal(vdbs_march_session_draw(session, &frame, &options, &plain, &err), VDBS_OK);

    double lo[3], hi[3];
    vdbs_volume_support_bounds(&volume, lo, hi);
    vdbs_shadow_sun_frame f;
    assert_int_equal(vdbs_shadow_sun_frame_fit(scene.lights[0].direction, lo, hi, &f, &err),
                     VDBS_OK);
    enum { MAP = 8 };
    float depths[MAP * MAP];
    vdbs_shadow_table open_sky, roof;
    for (int n = 0; n < MAP * MAP; ++n)
        depths[n] = VDBS_NO_OCCLUDER;
    assert_int_equal(vdbs_shadow_table_init(&open_sky, 1, &err), VDBS_OK);
    assert_int_equal(vdbs_shadow_table_set_sun(&open_sky, 0, &f, MAP, depths, 0.0, &err), VDBS_OK);
    vdbs_march_session_set_shadows(session, open_sky.data, open_sky.floats);
    assert_int_equal(vdbs_march_session_draw(session, &frame, &options, &shot, &err), VDBS_OK);
    for (int i = 0; i < 3 * 16 * 12; ++i)
        assert_true(shot.rgb[i] == plain.rgb[i]);

    /* A roof over the whole map, before the volume. */
    for (int n = 0; n < MAP * MAP; ++n)
        depths[n] = 0.0f;
    assert_int_equal(vdbs_shadow_table_init(&roof, 1, &err), VDBS_OK);
    assert_int_equal(vdbs_shadow_table_set_sun(&roof, 0, &f, MAP, depths, 0.0, &err), VDBS_OK);
    vdbs_march_session_set_shadows(session, roof.data, roof.floats);
    assert_int_equal(vdbs_march_session_draw(session, &frame, &options, &shot, &err), VDBS_OK);
    vdbs_scene sunless = scene;
    sunless.lights[0].color[0] = sunless.lights[0].color[1] = sunless.lights[0].color[2] = 0.0;
    assert_int_equal(
        vdbs_render_march(runner, &volume, NULL, &sunless, &frame, &options, &dark, &err), VDBS_OK);
    double darker = 0.0;
    for (int i = 0; i < 3 * 16 * 12; ++i) {
        assert_true(fabsf(shot.rgb[i] - dark.rgb[i]) <= 1e-6f * (fabsf(dark.rgb[i]) + 1e-6f));
        darker += plain.rgb[i] - shot.rgb[i];
    }
    assert_true(darker > 0.0); /* the sun did light the cloud */

    /* A surface at the camera on every pixel. */
    float *backdrop = malloc(sizeof *backdrop * 4 * 16 * 12);
    for (int n = 0; n < 16 * 12; ++n) {
        backdrop[4 * n] = 0.0f;
        backdrop[4 * n + 1] = 0.125f;
        backdrop[4 * n + 2] = 0.25f;
        backdrop[4 * n + 3] = 0.5f;
    }
    options.backdrop = backdrop;
    assert_int_equal(vdbs_march_session_draw(session, &frame, &options, &shot, &err), VDBS_OK);
    for (int n = 0; n < 16 * 12; ++n)
        for (int c = 0; c < 3; ++c)
            assert_true(shot.rgb[3 * n + c] == backdrop[4 * n + 1 + c]);
    free(backdrop);
    vdbs_march_session_destroy(session);
    vdbs_shadow_table_free(&open_sky);
    vdbs_shadow_table_free(&roof);
    free(plain.rgb);
    free(dark.rgb);
    free(shot.rgb);
    vdbs_volume_free(&volume);
}

/* The fog pass over an empty medium: every pixel is the closed form of a point light's
 * fog (Biri) over the ray's span in the fog box, checked against the brute-force quadrature
 * of Eq. 3 (within 1%), plus the background seen through the fog. */
static void test_fog_pass_point_light(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_volume volume;
    test_sample_volume("cloud", 16, 1, &volume);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 0.0;
    scene.light_count = 2;
    scene.lights[0].type = VDBS_LIGHT_POINT;
    scene.lights[0].position[0] = 0.1;
    scene.lights[0].position[1] = 0.2;
    scene.lights[0].color[0] = scene.lights[0].color[1] = scene.lights[0].color[2] = 2.0;
    scene.lights[1].type = VDBS_LIGHT_ENV;
    scene.lights[1].color[0] = scene.lights[1].color[1] = scene.lights[1].color[2] = 0.25;
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_camera camera;
    vdbs_camera_frame frame;
    vdbs_camera_frame_volume(&volume, 24, 18, &camera);
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_fog_desc fd = {0};
    fd.sigma_t = 1.5;
    fd.albedo = 1.0;
    fd.g = 0.6;
    vdbs_fog fog;
    assert_int_equal(vdbs_fog_build(&fd, &fog, &err), VDBS_OK);
    vdbs_march_fog march_fog = {0};
    march_fog.fog = &fog;
    for (int a = 0; a < 3; ++a) {
        march_fog.box_lo[a] = -0.8;
        march_fog.box_hi[a] = 0.8;
        march_fog.albedo[a] = 0.5;
    }
    vdbs_march_options options = {0};
    options.sky_directions = 4;
    options.step_voxels = 1.0f;
    options.fog = &march_fog;
    vdbs_image image;
    image_init(&image, 24, 18);
    assert_int_equal(vdbs_render_march(test_runner(VDBS_BACKEND_CPU), &volume, NULL, &scene, &frame,
                                       &options, &image, &err),
                     VDBS_OK);
    double worst = 0.0;
    int checked = 0;
    for (int py = 0; py < 18; ++py)
        for (int px = 0; px < 24; ++px) {
            double d[3], enter = 0.0, exit = 1e30;
            vdbs_camera_ray(&frame, px + 0.5, py + 0.5, d);
            for (int a = 0; a < 3; ++a) {
                double t0 = (march_fog.box_lo[a] - frame.origin[a]) / d[a];
                double t1 = (march_fog.box_hi[a] - frame.origin[a]) / d[a];
                enter = fmax(enter, fmin(t0, t1));
                exit = fmin(exit, fmax(t0, t1));
            }
            double background = 0.25, expect = background;
            if (exit > enter) {
                double in = vdbs_fog_point_march(&fd, frame.origin, d, scene.lights[0].position,
                                                 2.0, enter, enter, exit);
                expect = 0.5 * in + exp(-fd.sigma_t * (exit - enter)) * background;
                ++checked;
            }
            double got = image.rgb[3 * (py * 24 + px)];
            worst = fmax(worst, fabs(got - expect) / expect);
        }
    print_message("fog pass against the brute-force quadrature: %d rays in the fog, worst relative "
                  "error %.2e\n",
                  checked, worst);
    assert_true(checked > 24 * 18 / 4);
    assert_true(worst < 0.01);
    vdbs_fog_free(&fog);
    free(image.rgb);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hg),
        cmocka_unit_test(test_one_minus_exp),
        cmocka_unit_test(test_ms_reconstruction),
        cmocka_unit_test(test_empty_medium_shows_env),
        cmocka_unit_test(test_slab_closed_form),
        cmocka_unit_test(test_baked_single_bake_equals_single),
        cmocka_unit_test(test_session_occluders),
        cmocka_unit_test(test_fog_pass_point_light),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
