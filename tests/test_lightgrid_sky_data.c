/* Sky grids sized by the sky's share of the light (lightgrid.h) on the Disney cloud
 * (wdas_cloud_sixteenth at density scale 0.2, 504k output voxels): a sun of 1 and a constant
 * 64-direction sky at the default oversampling, S1 from the default light grids against the
 * exact march (relative RMSE over voxels above 1e-3 of the maximum): the sizing adds at most
 * 0.15% to the error of the sky at the sun's spacing, and the whole stays within 1%; with the
 * sky as bright as in bench/s1.md (81% of the light) it keeps the sun's spacing, with a tenth
 * of it its grids are coarser. The marches of 65 lights take minutes: label "long". Skips
 * without the data folder. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/lightgrid.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/single.h"

static int teardown(void **state)
{
    (void)state;
    test_runners_free();
    return 0;
}

static double relrmse(const float *a, const float *b, size_t n)
{
    double peak = 0.0, num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; ++i)
        peak = fmax(peak, b[i]);
    for (size_t i = 0; i < n; ++i) {
        if (!(b[i] > 1e-3 * peak))
            continue;
        num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
        den += (double)b[i] * b[i];
    }
    return den > 0.0 ? sqrt(num / den) : 0.0;
}

static void sky_case(const vdbs_volume *volume, double f)
{
    vdbs_error err;
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 0.2;
    scene.light_count = 2;
    scene.lights[0].type = VDBS_LIGHT_SUN;
    const double dir[3] = {0.3, -1.0, 0.2}, sky[3] = {0.2, 0.3, 0.5};
    memcpy(scene.lights[0].direction, dir, sizeof dir);
    scene.lights[0].color[0] = scene.lights[0].color[1] = scene.lights[0].color[2] = 1.0;
    scene.lights[1].type = VDBS_LIGHT_ENV;
    for (int c = 0; c < 3; ++c)
        scene.lights[1].color[c] = f * sky[c];
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_lights_desc ld = {.sky_ordinates = 64};
    vdbs_light_table lights;
    if (vdbs_lights_build(volume, &scene, &ld, &lights, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    size_t n = 3 * volume->coord_count;
    float *exact = calloc(n, sizeof *exact), *grid = calloc(n, sizeof *grid);
    vdbs_runner *runner = test_runner(VDBS_BACKEND_CPU);
    assert_int_equal(vdbs_single_scatter(runner, volume, &scene, &lights, exact, NULL, &err),
                     VDBS_OK);
    vdbs_light_grid_desc gd = {0, 0, 0.0}, same_desc = {0, 0, -1.0};
    vdbs_s1_stats stats, same;
    assert_int_equal(
        vdbs_single_scatter_grids(runner, volume, &scene, &lights, &gd, grid, &stats, NULL, &err),
        VDBS_OK);
    double e = relrmse(grid, exact, n);
    assert_int_equal(vdbs_single_scatter_grids(runner, volume, &scene, &lights, &same_desc, grid,
                                               &same, NULL, &err),
                     VDBS_OK);
    double e_fine = relrmse(grid, exact, n);
    const vdbs_s1_kind_stats *s = &stats.kinds[VDBS_S1_SUN], *k = &stats.kinds[VDBS_S1_SKY];
    print_message("Disney cloud, sun + 64 sky x %g: sky spacing %.3g to %.3g (sun %.3g), relative "
                  "RMSE %.3e (%.3e at the sun's spacing)\n",
                  f, k->grids.spacing_min, k->grids.spacing_max, s->grids.spacing_min, e, e_fine);
    if (f < 1.0)
        assert_true(k->grids.spacing_min > s->grids.spacing_max);
    /* What the sizing adds: about 0.1% at most (lightgrid.h); the whole within the 1% of the
     * default oversampling (test_lightgrid.c). */
    assert_true(e <= e_fine + 0.0015);
    assert_true(e <= 0.01);
    free(exact);
    free(grid);
    vdbs_lights_free(&lights);
}

static void test_sky_sizing_disney_cloud(void **state)
{
    (void)state;
    vdbs_volume volume;
    vdbs_error err;
    vdbio_read_options read = {0};
    if (vdbs_volume_load(test_data_path("wdas_cloud_sixteenth.vdb"), &read, &volume, &err) !=
        VDBS_OK)
        fail_msg("%s", err.message);
    for (int dim = 0; dim < 2; ++dim)
        sky_case(&volume, dim ? 0.1 : 1.0);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sky_sizing_disney_cloud),
    };
    return cmocka_run_group_tests(tests, NULL, teardown);
}
