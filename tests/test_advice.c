/* The density scale for a target optical depth, and the warnings for scenes that are almost
 * certainly a mistake, on the homogeneous slab sample. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/advice.h"

typedef struct warnings {
    int count;
    char text[8][320];
} warnings;

static void collect(void *user, const char *message)
{
    warnings *w = user;
    if (w->count < 8)
        snprintf(w->text[w->count], sizeof w->text[0], "%s", message);
    w->count++;
}

static int said(const warnings *w, const char *needle)
{
    for (int i = 0; i < w->count && i < 8; ++i)
        if (strstr(w->text[i], needle))
            return 1;
    return 0;
}

static void load_slab(vdbs_volume *volume)
{
    vdbs_error err;
    vdbio_read_options read = {0};
    if (vdbs_volume_load(VDBS_TEST_SAMPLES_DIR "/slab.vdb", &read, volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

static void slab_scene(vdbs_scene *scene, double density_scale, double albedo)
{
    vdbs_scene_init(scene);
    scene->density_scale = density_scale;
    scene->albedo[0] = scene->albedo[1] = scene->albedo[2] = albedo;
    scene->light_count = 1;
    scene->lights[0].type = VDBS_LIGHT_SUN;
    scene->lights[0].direction[1] = -1.0;
    scene->lights[0].color[0] = scene->lights[0].color[1] = scene->lights[0].color[2] = 1.0;
}

/* The slab is 0.5 thick in y: a vertical ray through it meets a depth of 0.5 per unit
 * density (the trilinear ramp integrates to the step it smooths), and depth is linear in
 * the scale, so the fitted scale reproduces the target exactly. */
static void test_fit_density(void **state)
{
    (void)state;
    vdbs_volume volume;
    load_slab(&volume);
    vdbs_thickness t;
    vdbs_volume_thickness(&volume, 1.0, &t);
    assert_true(fabs(t.axis_max[1] - 0.5) < 1e-4);
    double mean = vdbs_volume_mean_depth(&volume);
    assert_true(mean > 0.0);
    assert_true(fabs(mean - (t.axis_mean[0] + t.axis_mean[1] + t.axis_mean[2]) / 3.0) <
                1e-12 * mean);

    vdbs_scene *scene = malloc(sizeof *scene);
    vdbs_error err;
    slab_scene(scene, 1.0, 0.5);
    assert_int_equal(vdbs_scene_fit_density(scene, &volume, &err), VDBS_OK);
    assert_true(scene->density_scale == 1.0); /* no target: unchanged */
    scene->density_target_depth = 10.0;
    assert_int_equal(vdbs_scene_fit_density(scene, &volume, &err), VDBS_OK);
    assert_true(scene->density_target_depth == 0.0);
    assert_true(fabs(scene->density_scale * mean - 10.0) < 1e-9);
    vdbs_advice advice;
    vdbs_scene_advise(scene, &volume, 1, NULL, NULL, &advice);
    assert_true(fabs(advice.mean_depth - 10.0) < 1e-4);
    free(scene);
    vdbs_volume_free(&volume);
}

static void test_warnings(void **state)
{
    (void)state;
    vdbs_volume volume;
    load_slab(&volume);
    vdbs_scene *scene = malloc(sizeof *scene);
    double mean = vdbs_volume_mean_depth(&volume);
    vdbs_advice advice;

    /* A plausible cloud: nothing to say with multiple scattering, a warning without it. */
    slab_scene(scene, 10.0 / mean, 0.99);
    warnings w = {0};
    vdbs_scene_advise(scene, &volume, 1, collect, &w, &advice);
    assert_int_equal(w.count, 0);
    double q = 0.99 * (1.0 - exp(-5.0));
    assert_true(fabs(advice.ms_to_ss - q / (1.0 - q)) < 1e-6 * advice.ms_to_ss);
    strcpy(scene->method, "single");
    vdbs_scene_advise(scene, &volume, 0, collect, &w, &advice);
    assert_int_equal(w.count, 1);
    assert_true(said(&w, "--method single leaves out multiple scattering"));

    /* Thin smoke, albedo 0.5, depth 1: single scattering dominates, nothing to say. */
    memset(&w, 0, sizeof w);
    slab_scene(scene, 1.0 / mean, 0.5);
    vdbs_scene_advise(scene, &volume, 0, collect, &w, &advice);
    assert_int_equal(w.count, 0);
    assert_true(advice.ms_to_ss < 0.25);

    /* Nearly invisible and far too thick. */
    slab_scene(scene, 0.05 / mean, 0.5);
    vdbs_scene_advise(scene, &volume, 1, collect, &w, &advice);
    assert_true(w.count == 1 && said(&w, "nearly invisible"));
    slab_scene(scene, 2e4 / mean, 0.5);
    vdbs_scene_advise(scene, &volume, 1, collect, &w, &advice);
    assert_true(w.count == 2 && said(&w, "only its skin"));

    /* A zero light, every light zero, density scale 0. */
    memset(&w, 0, sizeof w);
    slab_scene(scene, 0.0, 0.5);
    scene->lights[0].color[0] = scene->lights[0].color[1] = scene->lights[0].color[2] = 0.0;
    vdbs_scene_advise(scene, &volume, 1, collect, &w, &advice);
    assert_int_equal(advice.zero_lights, 1);
    assert_true(said(&w, "lights[0] (sun) is zero"));
    assert_true(said(&w, "every light is zero"));
    assert_true(said(&w, "density scale 0"));
    assert_int_equal(w.count, 3);
    free(scene);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fit_density),
        cmocka_unit_test(test_warnings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
