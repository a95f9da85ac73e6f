/* Shadow maps as the kernels read them (vdbscatter/shadow.h, shaders/vs_shadow.h): a sun's
 * orthographic map over a half plate and a point light's cube with one open face, each
 * against the geometry it was made from (depths written here by the same rules the
 * viewer's rasteriser follows). */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>

#include "vdbscatter/shadow.h"

/* A sun straight down on the box [-1, 1]^3; a plate at y = 0.5 over x < 0. */
static void test_sun_half_plate(void **state)
{
    (void)state;
    vdbs_error err;
    const double down[3] = {0.0, -1.0, 0.0}, lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    vdbs_shadow_sun_frame f;
    assert_int_equal(vdbs_shadow_sun_frame_fit(down, lo, hi, &f, &err), VDBS_OK);
    /* The frame: w along the light, u and v orthonormal, the plane before the box. */
    assert_true(fabs(f.w[1] + 1.0) < 1e-12);
    assert_true(fabs(f.u[0] * f.u[0] + f.u[1] * f.u[1] + f.u[2] * f.u[2] - 1.0) < 1e-12);
    assert_true(fabs(f.u[0] * f.v[0] + f.u[1] * f.v[1] + f.u[2] * f.v[2]) < 1e-12);
    assert_true(fabs(f.half - sqrt(3.0)) < 1e-12 && fabs(f.origin[1] - sqrt(3.0)) < 1e-12);
    enum { RES = 16 };
    float depths[RES * RES];
    for (int j = 0; j < RES; ++j)
        for (int i = 0; i < RES; ++i) {
            /* The texel centre's world point on the plane, then its x. */
            double x = ((i + 0.5) / RES * 2.0 - 1.0) * f.half,
                   y = ((j + 0.5) / RES * 2.0 - 1.0) * f.half;
            double wx = f.origin[0] + x * f.u[0] + y * f.v[0];
            depths[j * RES + i] = wx < 0.0 ? (float)(f.origin[1] - 0.5) : VDBS_NO_OCCLUDER;
        }
    vdbs_shadow_table t;
    assert_int_equal(vdbs_shadow_table_init(&t, 2, &err), VDBS_OK);
    assert_int_equal(vdbs_shadow_table_set_sun(&t, 0, &f, RES, depths, 1e-3, &err), VDBS_OK);
    const double under[3] = {-0.6, 0.0, 0.3}, beside[3] = {0.6, 0.0, 0.3},
                 above[3] = {-0.6, 0.8, 0.0};
    const double outside[3] = {-9.0, 0.0, 0.0};
    assert_true(vdbs_shadow_visibility(&t, 0, under) == 0.0f);
    assert_true(vdbs_shadow_visibility(&t, 0, beside) == 1.0f);
    assert_true(vdbs_shadow_visibility(&t, 0, above) == 1.0f);
    assert_true(vdbs_shadow_visibility(&t, 0, outside) == 1.0f);
    /* Light 1 has no map, a light beyond the table neither. */
    assert_true(vdbs_shadow_visibility(&t, 1, under) == 1.0f);
    assert_true(vdbs_shadow_visibility(&t, 5, under) == 1.0f);
    /* The filtered edge: half lit at the plate's edge, monotone across it. */
    float last = -1.0f;
    for (int s = -8; s <= 8; ++s) {
        const double p[3] = {s * (f.half / RES) / 4.0, 0.0, 0.3};
        float vis = vdbs_shadow_visibility(&t, 0, p);
        assert_true(vis >= last - 1e-6f);
        last = vis;
        if (s == 0)
            assert_true(fabsf(vis - 0.5f) < 1e-5f);
    }
    vdbs_shadow_table_free(&t);
}

/* A point light at (1, 2, 3) in a shell of radius 1 open on the +x face. */
static void test_cube_open_face(void **state)
{
    (void)state;
    vdbs_error err;
    enum { RES = 8 };
    float *d = malloc(sizeof *d * 6 * RES * RES);
    for (int f = 0; f < 6; ++f)
        for (int n = 0; n < RES * RES; ++n)
            d[f * RES * RES + n] = f == 0 ? VDBS_NO_OCCLUDER : 1.0f;
    vdbs_shadow_table t;
    const double at[3] = {1.0, 2.0, 3.0};
    assert_int_equal(vdbs_shadow_table_init(&t, 1, &err), VDBS_OK);
    assert_int_equal(vdbs_shadow_table_set_cube(&t, 0, at, RES, d, 1e-3, &err), VDBS_OK);
    const double far_x[3] = {3.0, 2.2, 2.9}, far_neg_y[3] = {1.1, -0.5, 3.2};
    const double near_neg_y[3] = {1.0, 1.5, 3.0}, far_z[3] = {0.8, 2.1, 6.0};
    assert_true(vdbs_shadow_visibility(&t, 0, far_x) == 1.0f);
    assert_true(vdbs_shadow_visibility(&t, 0, far_neg_y) == 0.0f);
    assert_true(vdbs_shadow_visibility(&t, 0, near_neg_y) == 1.0f);
    assert_true(vdbs_shadow_visibility(&t, 0, far_z) == 0.0f);
    vdbs_shadow_table_free(&t);
    free(d);
}

static void test_bad_input(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_shadow_sun_frame f;
    const double zero[3] = {0, 0, 0}, lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1}, down[3] = {0, -1, 0};
    assert_int_equal(vdbs_shadow_sun_frame_fit(zero, lo, hi, &f, &err), VDBS_ERR_INPUT);
    assert_int_equal(vdbs_shadow_sun_frame_fit(down, hi, lo, &f, &err), VDBS_ERR_INPUT);
    vdbs_shadow_table t;
    assert_int_equal(vdbs_shadow_table_init(&t, 1, &err), VDBS_OK);
    float one = 1.0f;
    assert_int_equal(vdbs_shadow_sun_frame_fit(down, lo, hi, &f, &err), VDBS_OK);
    assert_int_equal(vdbs_shadow_table_set_sun(&t, 1, &f, 1, &one, 0.0, &err), VDBS_ERR_INTERNAL);
    vdbs_shadow_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sun_half_plate),
        cmocka_unit_test(test_cube_open_face),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
