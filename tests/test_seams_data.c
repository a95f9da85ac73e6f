/* test_seams's bar (docs/design.md "Upsampling without seams") on a real cloud: the Disney
 * cloud at 1/16 resolution from the external test data (skipped without it) under
 * samples/cloud.json's sun and sky, albedo 0.99, g 0.85, --density-scale auto:10, as
 * bench/bench_defaults.py bakes it; POP, FLD and SVD at quality low, ms's seam ratio <= 1.5
 * on every axis. Label "long" (tests/CMakeLists.txt): scripts/test.sh --long runs it. */
#include "testutil.h"

#include <stdio.h>
#include <string.h>

#include "seams.h"
#include "seams_bake.h"
#include "vdbscatter/advice.h"
#include "vdbscatter/scene_file.h"

#define BAR 1.5
/* Lines that met enough medium on every axis (the fewest measured: 57, POP on the Disney
 * cloud across y, with 19 voxels per cell): the ratio is an average, not one line. */
#define MIN_LINES 40

static void wdas_low(const char *method)
{
    const char *path = test_data_path("wdas_cloud_sixteenth.vdb");
    vdbs_scene scene;
    vdbs_error err;
    if (vdbs_scene_load(VDBS_TEST_SAMPLES_DIR "/cloud.json", &scene, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    snprintf(scene.volume_file, sizeof scene.volume_file, "%s", path);
    scene.albedo[0] = scene.albedo[1] = scene.albedo[2] = 0.99;
    scene.g = 0.85;
    if (vdbs_scene_set_density_scale(&scene, "test", "auto:10", &err) != VDBS_OK)
        fail_msg("%s", err.message);
    snprintf(scene.method, sizeof scene.method, "%s", method);
    snprintf(scene.quality, sizeof scene.quality, "low");
    vdbs_volume volume;
    vdbio_read_options read = {0};
    if (vdbs_volume_load(path, &read, &volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    /* auto:10 resolved against the volume, as the bake does. */
    if (vdbs_scene_fit_density(&scene, &volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    test_seams ms, l1[3];
    test_seams_bake(&volume, &scene, &ms, l1);
    for (int a = 0; a < 3; ++a)
        print_message(
            "%s low, Disney cloud, axis %d (%.2f voxels per cell, %ld lines): ms %.3f, ms_l1 "
            "%.3f %.3f %.3f\n",
            method, a, ms.cell_voxels[a], ms.lines[a], ms.ratio[a], l1[0].ratio[a], l1[1].ratio[a],
            l1[2].ratio[a]);
    for (int a = 0; a < 3; ++a) {
        assert_true(ms.lines[a] >= MIN_LINES);
        assert_true(ms.ratio[a] > 0.0 && ms.ratio[a] <= BAR);
        for (int m = 0; m < 3; ++m)
            assert_true(l1[m].ratio[a] > 0.0 && l1[m].ratio[a] <= BAR);
    }
    vdbs_volume_free(&volume);
}

static void test_pop_wdas(void **state)
{
    (void)state;
    wdas_low("pop");
}

static void test_fld_wdas(void **state)
{
    (void)state;
    wdas_low("fld");
}

static void test_svd_wdas(void **state)
{
    (void)state;
    wdas_low("svd");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pop_wdas),
        cmocka_unit_test(test_fld_wdas),
        cmocka_unit_test(test_svd_wdas),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    test_runners_free();
    return rc;
}
