/* The single-scattering compute shader against its C twin (the same kernel text):
 * relative agreement 1e-5 wherever |v| >= 1e-30, on a procedural cloud and on a real
 * file with a rotated, non-uniform transform and active tiles. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/gpu.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/single.h"
#include "vdbscatter/volume.h"

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

static void compare(const vdbs_volume *volume, const vdbs_scene *scene, int sky)
{
    size_t n = 3 * volume->coord_count;
    float *cpu = malloc(sizeof(float) * n);
    float *gl = malloc(sizeof(float) * n);
    vdbs_error err;
    assert_int_equal(vdbs_single_scatter_cpu(volume, scene, sky, cpu, NULL, &err), VDBS_OK);
    if (vdbs_single_scatter_gpu(gpu, volume, scene, sky, gl, NULL, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    size_t compared = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; ++i) {
        assert_true(isfinite(gl[i]) && gl[i] >= 0.0f);
        if (fabs(cpu[i]) < 1e-30 && fabs(gl[i]) < 1e-30)
            continue;
        double d = test_rel_diff(cpu[i], gl[i]);
        worst = fmax(worst, d);
        if (d > 1e-5)
            fail_msg("value %zu (voxel %d,%d,%d): C %.9g GLSL %.9g", i, volume->coords[i / 3 * 3],
                     volume->coords[i / 3 * 3 + 1], volume->coords[i / 3 * 3 + 2], cpu[i], gl[i]);
        ++compared;
    }
    print_message("compared %zu values, worst relative difference %.3g\n", compared, worst);
    assert_true(compared > n / 2);
    free(cpu);
    free(gl);
}

static void test_cloud(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("cloud", 32, 3, &density, &err), VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 12.0;
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    compare(&volume, &scene, 16);
    scene.density_scale = 400.0; /* deep shadows: values down to the 1e-30 cut */
    compare(&volume, &scene, 16);
    vdbs_volume_free(&volume);
}

/* 1 + 2 + 1024 marches per voxel are far beyond llvmpipe's 65535 loop iterations per
 * invocation: the shader must split them into passes and still agree with C. */
static void test_many_sky_directions(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("cloud", 20, 5, &density, &err), VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 20.0;
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    compare(&volume, &scene, 1024);
    vdbs_volume_free(&volume);
}

static void test_real_rotated_file(void **state)
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
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    compare(&volume, &scene, 4);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cloud),
        cmocka_unit_test(test_many_sky_directions),
        cmocka_unit_test(test_real_rotated_file),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
