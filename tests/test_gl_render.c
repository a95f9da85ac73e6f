/* The ray-march render shader against its C twin (the same kernel text, vs_render.h):
 * relative agreement 1e-5 wherever |v| >= 1e-30, per pixel and channel, 32x32 images, in
 * single mode (procedural cloud; real file with a rotated, non-uniform transform) and in
 * baked mode (synthetic ms / ms_l1 grids with varying directions and anisotropies). */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/gpu.h"
#include "vdbscatter/render.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#define SIZE 32

static vdbs_gpu *gpu;

static int setup(void **state)
{
    (void)state;
    vdbs_error err;
    if (vdbs_gpu_create(&gpu, &err) != VDBS_OK) {
        fprintf(stderr, "no GL context: %s\n", err.message);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    vdbs_gpu_destroy(gpu);
    return 0;
}

static void image_init(vdbs_image *image)
{
    memset(image, 0, sizeof *image);
    image->width = SIZE;
    image->height = SIZE;
    image->rgb = calloc(3 * SIZE * SIZE, sizeof(float));
    assert_non_null(image->rgb);
}

static void compare(const vdbs_volume *volume, const vdbs_ms_grids *ms, const vdbs_scene *scene,
                    const vdbs_march_options *options)
{
    vdbs_camera camera;
    vdbs_camera_frame frame;
    vdbs_error err;
    vdbs_camera_frame_volume(volume, SIZE, SIZE, &camera);
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_image cpu, gl;
    image_init(&cpu);
    image_init(&gl);
    if (vdbs_render_march_cpu(volume, ms, scene, &frame, options, &cpu, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_render_march_gpu(gpu, volume, ms, scene, &frame, options, &gl, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    size_t n = 3 * SIZE * SIZE, compared = 0, lit = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; ++i) {
        assert_true(isfinite(cpu.rgb[i]) && cpu.rgb[i] >= 0.0f);
        assert_true(isfinite(gl.rgb[i]) && gl.rgb[i] >= 0.0f);
        if (fabs(cpu.rgb[i]) < 1e-30 && fabs(gl.rgb[i]) < 1e-30)
            continue;
        double d = test_rel_diff(cpu.rgb[i], gl.rgb[i]);
        worst = fmax(worst, d);
        if (d > 1e-5)
            fail_msg("pixel %zu,%zu channel %zu: C %.9g GLSL %.9g", i / 3 % SIZE, i / 3 / SIZE,
                     i % 3, cpu.rgb[i], gl.rgb[i]);
        ++compared;
        /* Pixels that see the medium (not just the background). */
        if (cpu.rgb[i] != cpu.rgb[i % 3])
            ++lit;
    }
    print_message("compared %zu values (%zu differ from the corner), worst relative "
                  "difference %.3g\n",
                  compared, lit, worst);
    assert_true(compared > n / 2);
    assert_true(lit > n / 20); /* the medium covers part of the frame at least */
    free(cpu.rgb);
    free(gl.rgb);
}

static void cloud(vdbs_volume *volume)
{
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("cloud", 32, 3, &density, &err), VDBS_OK);
    assert_int_equal(vdbs_volume_from_density(density, volume, &err), VDBS_OK);
}

static void test_single_cloud(void **state)
{
    (void)state;
    vdbs_volume volume;
    cloud(&volume);
    vdbs_scene scene;
    vdbs_error err;
    vdbs_scene_init(&scene);
    scene.density_scale = 12.0;
    scene.g = 0.7;
    scene.albedo[1] = 0.9;
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_march_options options = {16, 1.0f, NULL, 0};
    compare(&volume, NULL, &scene, &options);
    scene.density_scale = 400.0; /* opaque core: transmittances down to the 1e-30 cut */
    scene.g = -0.999;
    compare(&volume, NULL, &scene, &options);
    vdbs_volume_free(&volume);
}

static void test_single_real_rotated_file(void **state)
{
    (void)state;
    vdbs_volume volume;
    vdbs_error err;
    vdbio_read_options read = {0};
    if (vdbs_volume_load(test_data_path("vpt_dragon_with_xform.vdb"), &read, &volume, &err) !=
        VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 5.0;
    scene.g = 0.5;
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_march_options options = {4, 2.0f, NULL, 0};
    compare(&volume, NULL, &scene, &options);
    vdbs_volume_free(&volume);
}

/* Writes a lit VDB over the cloud's output voxels with smoothly varying ms > 0 and
 * first moments of varying direction and length up to 2.7 ms (b up to 0.9). */
/* The GPU path's passes: one march per pixel and dispatch, and a budget far beyond the
 * driver's loop limit (detected by the canary and repeated with fewer units), give the
 * same bits as the automatic budget: the ray state survives between passes unchanged. */
static void test_gpu_passes(void **state)
{
    (void)state;
    vdbs_volume volume;
    cloud(&volume);
    vdbs_scene scene;
    vdbs_error err;
    vdbs_scene_init(&scene);
    scene.density_scale = 12.0;
    scene.g = 0.7;
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_camera camera;
    vdbs_camera_frame frame;
    vdbs_camera_frame_volume(&volume, SIZE, SIZE, &camera);
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    const int units[3] = {0, 1, 1 << 30};
    vdbs_image images[3];
    for (int i = 0; i < 3; ++i) {
        vdbs_march_options options = {16, 1.0f, NULL, units[i]};
        image_init(&images[i]);
        if (vdbs_render_march_gpu(gpu, &volume, NULL, &scene, &frame, &options, &images[i], &err) !=
            VDBS_OK)
            fail_msg("%s", err.message);
    }
    for (int i = 1; i < 3; ++i) {
        assert_memory_equal(images[0].rgb, images[i].rgb, 3 * SIZE * SIZE * sizeof(float));
        free(images[i].rgb);
    }
    free(images[0].rgb);
    vdbs_volume_free(&volume);
}

static void write_synthetic_lit(const vdbs_volume *volume, const char *path)
{
    size_t n = volume->coord_count;
    float *ms = malloc(3 * n * sizeof(float));
    float *l1[3];
    for (int a = 0; a < 3; ++a)
        l1[a] = malloc(3 * n * sizeof(float));
    for (size_t v = 0; v < n; ++v) {
        const int32_t *c = volume->coords + 3 * v;
        for (int ch = 0; ch < 3; ++ch) {
            double m = 0.2 + 0.1 * ch + 0.05 * sin(0.3 * c[0] + ch) * cos(0.2 * c[1]);
            double theta = 0.15 * c[2] + 0.7 * ch, phi = 0.1 * c[0] - 0.13 * c[1];
            double b = 0.45 + 0.45 * sin(0.17 * c[1] + 0.3 * ch);
            double dir[3] = {sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta)};
            ms[3 * v + ch] = (float)m;
            for (int a = 0; a < 3; ++a)
                l1[a][3 * v + ch] = (float)(3.0 * m * b * dir[a]);
        }
    }
    vdbio_vec3_grid grids[] = {
        {"radiance", ms}, {"ms", ms}, {"ms_l1x", l1[0]}, {"ms_l1y", l1[1]}, {"ms_l1z", l1[2]},
    };
    vdbio_write_request request = {0};
    request.density = volume->density;
    request.coords = volume->coords;
    request.coord_count = n;
    request.vec3_grids = grids;
    request.vec3_grid_count = 5;
    vdbs_error err;
    if (vdbio_write(path, NULL, &request, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    free(ms);
    for (int a = 0; a < 3; ++a)
        free(l1[a]);
}

static void test_baked_synthetic(void **state)
{
    (void)state;
    vdbs_volume volume;
    cloud(&volume);
    const char *path = test_tmp_path("gl_render_lit.vdb");
    write_synthetic_lit(&volume, path);
    vdbs_error err;
    vdbs_ms_grids ms;
    test_load_ms_grids(path, volume.index_to_world, &ms);

    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 8.0;
    scene.g = 0.85;
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_march_options options = {16, 1.0f, NULL, 0};
    compare(&volume, &ms, &scene, &options);
    vdbs_ms_grids_free(&ms);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_cloud),
        cmocka_unit_test(test_single_real_rotated_file),
        cmocka_unit_test(test_gpu_passes),
        cmocka_unit_test(test_baked_synthetic),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
