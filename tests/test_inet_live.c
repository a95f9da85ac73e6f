/* Live multiple scattering on an illumination network (inet_live.h), on the C path, on the
 * cloud sample at quality low with a sky and a sun that moves from A to B:
 * - warm start after a light move: the relative RMSE of ms against a fresh object's ms for B
 *   (solved to a residual of 1e-4) falls monotonically over 1, 2 and 5 sweeps, and after 5 it
 *   is at most a quarter of the stale error (A's converged ms against B's);
 * - at the fixed point: set_lights with the same lights and one sweep changes ms by less than
 *   the quality's residual;
 * - vdbs_inet_live_ms is vdbs_inet_to_voxels of the live state. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/inet_live.h"

typedef struct ms_grids {
    float *ms, *l1[3];
} ms_grids;

static void grids_alloc(ms_grids *g, size_t voxels)
{
    g->ms = calloc(3 * voxels, sizeof *g->ms);
    assert_non_null(g->ms);
    for (int a = 0; a < 3; ++a) {
        g->l1[a] = calloc(3 * voxels, sizeof *g->l1[a]);
        assert_non_null(g->l1[a]);
    }
}

static void grids_free(ms_grids *g)
{
    free(g->ms);
    for (int a = 0; a < 3; ++a)
        free(g->l1[a]);
}

static void live_ms(const vdbs_inet_live *live, ms_grids *g)
{
    vdbs_error err;
    if (vdbs_inet_live_ms(live, g->ms, g->l1, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* sqrt(sum (a - b)^2 / sum b^2) over voxels and channels. */
static double relative_rmse(const float *a, const float *b, size_t n)
{
    double num = 0.0, den = 0.0;
    for (size_t k = 0; k < n; ++k) {
        const double e = (double)a[k] - (double)b[k];
        num += e * e;
        den += (double)b[k] * (double)b[k];
    }
    return den > 0.0 ? sqrt(num / den) : sqrt(num);
}

/* The cloud sample's medium and sky (samples/cloud.json) with one sun. */
static void cloud_scene(vdbs_scene *scene, double dx, double dy, double dz)
{
    vdbs_scene_init(scene);
    scene->density_scale = 20.0;
    scene->albedo[0] = scene->albedo[1] = scene->albedo[2] = 0.99;
    scene->g = 0.85;
    snprintf(scene->quality, sizeof scene->quality, "low");
    scene->light_count = 2;
    const double norm = sqrt(dx * dx + dy * dy + dz * dz);
    scene->lights[0].type = VDBS_LIGHT_SUN;
    scene->lights[0].direction[0] = dx / norm;
    scene->lights[0].direction[1] = dy / norm;
    scene->lights[0].direction[2] = dz / norm;
    scene->lights[0].color[0] = 3.0;
    scene->lights[0].color[1] = 2.9;
    scene->lights[0].color[2] = 2.7;
    scene->lights[1].type = VDBS_LIGHT_ENV;
    scene->lights[1].color[0] = 0.2;
    scene->lights[1].color[1] = 0.3;
    scene->lights[1].color[2] = 0.5;
    scene->lights[1].env_scale = 1.0;
}

static vdbs_inet_live *live_create(const vdbs_volume *volume, const vdbs_scene *scene)
{
    vdbs_inet_live_desc d = {.volume = volume, .scene = scene};
    vdbs_inet_live *live = NULL;
    vdbs_error err;
    if (vdbs_inet_live_create(&d, &live, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_inet_live_status st;
    assert_int_equal(vdbs_inet_live_sweep(live, 0, &st, &err), VDBS_OK);
    printf("created: %d sweeps, change %.3g (tolerance %.3g)%s\n", st.sweeps, st.change,
           st.tolerance, st.converged ? ", converged" : "");
    return live;
}

static void test_warm_start_after_a_light_move(void **unused)
{
    (void)unused;
    vdbs_volume volume;
    test_sample_volume("cloud", 24, 7, &volume);
    const size_t n = 3 * volume.coord_count;
    vdbs_scene *a = malloc(sizeof *a), *b = malloc(sizeof *b);
    assert_non_null(a);
    assert_non_null(b);
    cloud_scene(a, 0.3, -1.0, 0.2);
    cloud_scene(b, -0.6, -0.6, 0.5);
    vdbs_inet_live *live = live_create(&volume, a);
    /* The target is B's fixed point: solved far below the quality's residual, which the live
     * sweeps approach beyond it. */
    vdbs_error err;
    vdbs_scene *tight = malloc(sizeof *tight);
    assert_non_null(tight);
    *tight = *b;
    assert_int_equal(vdbs_scene_solver_store(tight, "inet_residual", 1e-4, &err), VDBS_OK);
    vdbs_inet_live *fresh = live_create(&volume, tight);
    ms_grids target, stale, now;
    grids_alloc(&target, volume.coord_count);
    grids_alloc(&stale, volume.coord_count);
    grids_alloc(&now, volume.coord_count);
    live_ms(fresh, &target);
    live_ms(live, &stale);
    const double stale_error = relative_rmse(stale.ms, target.ms, n);

    assert_int_equal(vdbs_inet_live_set_lights(live, b, &err), VDBS_OK);
    const int marks[3] = {1, 2, 5};
    double errors[3];
    int done = 0;
    for (int m = 0; m < 3; ++m) {
        vdbs_inet_live_status st;
        assert_int_equal(vdbs_inet_live_sweep(live, marks[m] - done, &st, &err), VDBS_OK);
        done = marks[m];
        assert_int_equal(st.sweeps, done);
        live_ms(live, &now);
        errors[m] = relative_rmse(now.ms, target.ms, n);
        printf("after %d sweeps: ms error %.4f, change %.3g\n", done, errors[m], st.change);
    }
    printf("stale: ms error %.4f; 5 sweeps / stale %.3f\n", stale_error, errors[2] / stale_error);
    assert_true(stale_error > 0.05); /* the move matters */
    assert_true(errors[0] > errors[1] && errors[1] > errors[2]);
    assert_true(errors[2] <= 0.25 * stale_error);

    /* ms is the splat of the live state. */
    ms_grids direct;
    grids_alloc(&direct, volume.coord_count);
    const vdbs_inet_problem problem = vdbs_inet_live_problem(live);
    assert_int_equal(vdbs_inet_to_voxels(&problem, vdbs_inet_live_state(live), &volume,
                                         a->density_scale, a->g, direct.ms, direct.l1, NULL, NULL,
                                         &err),
                     VDBS_OK);
    for (size_t k = 0; k < n; ++k) {
        assert_true(fabsf(direct.ms[k] - now.ms[k]) <= 1e-6f * fabsf(direct.ms[k]) + 1e-30f);
        for (int ax = 0; ax < 3; ++ax)
            assert_true(fabsf(direct.l1[ax][k] - now.l1[ax][k]) <=
                        1e-6f * fabsf(direct.l1[ax][k]) + 1e-30f);
    }

    grids_free(&direct);
    grids_free(&target);
    grids_free(&stale);
    grids_free(&now);
    vdbs_inet_live_destroy(live);
    vdbs_inet_live_destroy(fresh);
    free(a);
    free(b);
    free(tight);
    vdbs_volume_free(&volume);
}

/* Converged and re-seeded for the same lights: a sweep moves ms by less than the residual. */
static void test_fixed_point(void **unused)
{
    (void)unused;
    vdbs_volume volume;
    test_sample_volume("cloud", 24, 7, &volume);
    const size_t n = 3 * volume.coord_count;
    vdbs_scene *a = malloc(sizeof *a);
    assert_non_null(a);
    cloud_scene(a, 0.3, -1.0, 0.2);
    vdbs_inet_live *live = live_create(&volume, a);
    ms_grids before, after;
    grids_alloc(&before, volume.coord_count);
    grids_alloc(&after, volume.coord_count);
    live_ms(live, &before);
    vdbs_error err;
    vdbs_inet_live_status st;
    assert_int_equal(vdbs_inet_live_set_lights(live, a, &err), VDBS_OK);
    assert_int_equal(vdbs_inet_live_sweep(live, 1, &st, &err), VDBS_OK);
    live_ms(live, &after);
    const double moved = relative_rmse(after.ms, before.ms, n);
    printf("same lights, 1 sweep: change %.3g, ms moved %.3g (residual %.3g)\n", st.change, moved,
           st.tolerance);
    assert_int_equal(st.sweeps, 1);
    assert_true(moved < st.tolerance);
    grids_free(&before);
    grids_free(&after);
    vdbs_inet_live_destroy(live);
    free(a);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_warm_start_after_a_light_move),
        cmocka_unit_test(test_fixed_point),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
