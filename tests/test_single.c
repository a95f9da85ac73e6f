/* Single scattering on the C path against closed forms: exp(-tau) of a homogeneous
 * block under a normal sun (also through a rotated, non-uniform transform), point
 * lights in a homogeneous medium, an empty medium under a constant sky, and the exact
 * march against brute-force quadrature of the interpolant through a cloud. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

#include "vdbscatter/sphere.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/single.h"
#include "vdbscatter/volume.h"

#define PI 3.14159265358979323846

/* A homogeneous n^3 block of density 1, voxel (0,0,0) at the origin of index space,
 * mapped to world by `m` (row-major 3x4). */
static void make_block(int n, const double m[3][4], vdbs_volume *volume)
{
    float *values = malloc(sizeof(float) * (size_t)n * n * n);
    for (int i = 0; i < n * n * n; ++i)
        values[i] = 1.0f;
    int dims[3] = {n, n, n}, origin[3] = {0, 0, 0};
    vdbio_transform xf;
    memcpy(xf.m, m, sizeof xf.m);
    test_dense_volume(values, dims, origin, &xf, volume);
}

static void scale_transform(double h, double m[3][4])
{
    memset(m, 0, sizeof(double) * 12);
    m[0][0] = m[1][1] = m[2][2] = h;
}

static float *solve(const vdbs_volume *volume, const vdbs_scene *scene, int sky)
{
    float *radiance = malloc(sizeof(float) * 3 * volume->coord_count);
    vdbs_error err;
    vdbs_status st =
        test_single_scatter(test_runner(VDBS_BACKEND_CPU), volume, scene, sky, radiance, &err);
    if (st != VDBS_OK)
        fail_msg("%s", err.message);
    return radiance;
}

static void sun_scene(vdbs_scene *scene, double sigma_t, const double dir[3], double e)
{
    vdbs_scene_init(scene);
    scene->density_scale = sigma_t;
    scene->light_count = 1;
    scene->lights[0].type = VDBS_LIGHT_SUN;
    memcpy(scene->lights[0].direction, dir, sizeof(double) * 3);
    scene->lights[0].color[0] = e;
    scene->lights[0].color[1] = 2 * e;
    scene->lights[0].color[2] = 0.5 * e;
}

/* Checks radiance against E exp(-tau_j) / 4pi on every voxel at least two voxels from
 * the side faces, tau_j = (n - 0.5 - j) h sigma_t; returns how many voxels were checked. */
static int check_block(const vdbs_volume *volume, const float *radiance, int n, double h,
                       double sigma_t, double e)
{
    int checked = 0;
    for (size_t v = 0; v < volume->coord_count; ++v) {
        const int32_t *c = volume->coords + 3 * v;
        for (int k = 0; k < 3; ++k) {
            assert_true(isfinite(radiance[3 * v + k]));
            assert_true(radiance[3 * v + k] >= 0.0f);
        }
        if (c[0] < 2 || c[0] > n - 3 || c[2] < 2 || c[2] > n - 3 || c[1] < 0 || c[1] >= n)
            continue;
        double tau = (n - 0.5 - c[1]) * h * sigma_t;
        double expected = e * exp(-tau) / (4.0 * PI);
        double tol = tau <= 20.0 ? 1e-3 : (tau <= 50.0 ? 1e-2 : -1.0);
        if (tol < 0.0)
            continue;
        double got = radiance[3 * v];
        if (fabs(got - expected) > tol * expected)
            fail_msg("voxel (%d,%d,%d) sigma_t %g tau %g: got %.9g expected %.9g", c[0], c[1], c[2],
                     sigma_t, tau, got, expected);
        assert_true(fabs(radiance[3 * v + 1] - 2.0 * got) <= 1e-6 * got);
        ++checked;
    }
    return checked;
}

static void test_block_normal_sun(void **state)
{
    (void)state;
    const int n = 24;
    const double h = 0.1;
    double m[3][4];
    scale_transform(h, m);
    vdbs_volume volume;
    make_block(n, m, &volume);
    const double sigmas[] = {0.01, 0.1, 1.0, 10.0, 100.0};
    const double down[3] = {0.0, -1.0, 0.0};
    for (size_t s = 0; s < sizeof sigmas / sizeof *sigmas; ++s) {
        vdbs_scene scene;
        sun_scene(&scene, sigmas[s], down, 3.0);
        float *radiance = solve(&volume, &scene, 0);
        int checked = check_block(&volume, radiance, n, h, sigmas[s], 3.0);
        assert_true(checked >= 20 * 20 * 5);
        free(radiance);
    }
    vdbs_volume_free(&volume);
}

/* The same block through a rotated map with a different length per index axis: the sun
 * travels along the world image of index -Y, so the closed form holds with h = |A e_y|. */
static void test_block_rotated_nonuniform(void **state)
{
    (void)state;
    const int n = 20;
    const double c = cos(0.7), s = sin(0.7), c2 = cos(-0.4), s2 = sin(-0.4);
    const double scale[3] = {0.07, 0.13, 0.05};
    /* A = Rz(0.7) * Rx(-0.4) * diag(scale), plus a translation. */
    double r[3][3] = {{c, -s * c2, s * s2}, {s, c * c2, -c * s2}, {0.0, s2, c2}};
    double m[3][4];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            m[i][j] = r[i][j] * scale[j];
        m[i][3] = 0.3 * (i + 1);
    }
    vdbs_volume volume;
    make_block(n, m, &volume);
    double ey[3] = {-m[0][1], -m[1][1], -m[2][1]};
    double h = sqrt(ey[0] * ey[0] + ey[1] * ey[1] + ey[2] * ey[2]);
    assert_true(fabs(h - 0.13) < 1e-12);
    const double sigmas[] = {0.5, 5.0, 30.0};
    for (size_t k = 0; k < sizeof sigmas / sizeof *sigmas; ++k) {
        vdbs_scene scene;
        sun_scene(&scene, sigmas[k], ey, 1.0);
        float *radiance = solve(&volume, &scene, 0);
        assert_true(check_block(&volume, radiance, n, h, sigmas[k], 1.0) >= 16 * 16 * 5);
        free(radiance);
    }
    vdbs_volume_free(&volume);
}

/* A point light inside a large homogeneous block: voxels whose straight path to the light
 * stays in the interior see I exp(-sigma_t r) / (4 pi r^2). */
static void test_point_light_homogeneous(void **state)
{
    (void)state;
    const int n = 32;
    const double h = 0.05;
    double m[3][4];
    scale_transform(h, m);
    m[0][3] = -1.0;
    vdbs_volume volume;
    make_block(n, m, &volume);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 4.0;
    scene.light_count = 1;
    scene.lights[0].type = VDBS_LIGHT_POINT;
    double light_index[3] = {15.5, 15.25, 16.0};
    for (int a = 0; a < 3; ++a)
        scene.lights[0].position[a] = light_index[a] * h + m[a][3];
    scene.lights[0].color[0] = scene.lights[0].color[1] = scene.lights[0].color[2] = 7.0;
    float *radiance = solve(&volume, &scene, 0);
    int checked = 0;
    for (size_t v = 0; v < volume.coord_count; ++v) {
        const int32_t *c = volume.coords + 3 * v;
        int inside = 1;
        for (int a = 0; a < 3; ++a)
            inside &= c[a] >= 1 && c[a] <= n - 2;
        if (!inside)
            continue;
        double d[3] = {(c[0] - light_index[0]) * h, (c[1] - light_index[1]) * h,
                       (c[2] - light_index[2]) * h};
        double r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double rc = fmax(r, 0.5 * h);
        double expected = 7.0 * exp(-4.0 * r) / (4.0 * PI * rc * rc);
        if (test_rel_diff(radiance[3 * v], expected) > 1e-4)
            fail_msg("voxel (%d,%d,%d): got %.9g expected %.9g", c[0], c[1], c[2], radiance[3 * v],
                     expected);
        ++checked;
    }
    assert_true(checked == (n - 2) * (n - 2) * (n - 2));
    free(radiance);
    vdbs_volume_free(&volume);
}

/* With density scale 0 the sky reaches every voxel unattenuated: S1 average = L_sky. */
static void test_sky_without_medium(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("sphere", 16, 1, &density, &err), VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 0.0;
    scene.light_count = 1;
    scene.lights[0].type = VDBS_LIGHT_ENV;
    scene.lights[0].color[0] = 0.2;
    scene.lights[0].color[1] = 0.3;
    scene.lights[0].color[2] = 0.5;
    float *radiance = solve(&volume, &scene, 64);
    for (size_t v = 0; v < volume.coord_count; ++v) {
        assert_true(test_rel_diff(radiance[3 * v], 0.2) < 1e-5);
        assert_true(test_rel_diff(radiance[3 * v + 2], 0.5) < 1e-5);
    }
    free(radiance);
    vdbs_volume_free(&volume);
}

static void test_sphere_directions_balanced(void **state)
{
    (void)state;
    for (int k = 16; k <= 1024; k *= 4) {
        double *d = malloc(sizeof(double) * 3 * k);
        vdbs_sphere_directions(k, d);
        double sum[3] = {0, 0, 0};
        for (int i = 0; i < k; ++i) {
            double len = sqrt(d[3 * i] * d[3 * i] + d[3 * i + 1] * d[3 * i + 1] +
                              d[3 * i + 2] * d[3 * i + 2]);
            assert_true(fabs(len - 1.0) < 1e-12);
            for (int a = 0; a < 3; ++a)
                sum[a] += d[3 * i + a];
        }
        /* The lattice is symmetric in z and nearly balanced in x, y. */
        for (int a = 0; a < 3; ++a)
            assert_true(fabs(sum[a]) / k < 0.05);
        free(d);
    }
}

/* The exact march against a fine composite-Simpson quadrature of the interpolant (which
 * knows nothing about cells or empty-space skipping) along rays through a cloud. */
static void test_march_matches_quadrature(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("cloud", 40, 7, &density, &err), VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume.nano, volume.nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    float lo[3], hi[3];
    vdbs_volume_support_box(&volume, lo, hi);
    uint32_t rng = 12345u;
    int nonzero = 0;
    for (int ray = 0; ray < 200; ++ray) {
        float o[3], d[3];
        for (int a = 0; a < 3; ++a) {
            rng = rng * 1664525u + 1013904223u;
            o[a] = lo[a] + (hi[a] - lo[a]) * (float)(rng >> 8) / 16777216.0f;
        }
        double len = 0.0;
        do {
            len = 0.0;
            for (int a = 0; a < 3; ++a) {
                rng = rng * 1664525u + 1013904223u;
                d[a] = 2.0f * (float)(rng >> 8) / 16777216.0f - 1.0f;
                len += d[a] * d[a];
            }
        } while (len < 0.01 || len > 1.0);
        /* index-space step per unit world length: voxel size 2/40 */
        for (int a = 0; a < 3; ++a)
            d[a] = (float)(d[a] / sqrt(len) / 0.05);
        float tmax = 3.0f;
        float tau =
            vs_optical_depth(buf, &acc, vs_vec3(o[0], o[1], o[2]), vs_vec3(d[0], d[1], d[2]), tmax,
                             vs_vec3(lo[0], lo[1], lo[2]), vs_vec3(hi[0], hi[1], hi[2]), 1.0f);
        const int steps = 20000;
        double sum = 0.0;
        for (int i = 0; i <= steps; ++i) {
            double t = tmax * i / steps;
            float p[3] = {(float)(o[0] + d[0] * t), (float)(o[1] + d[1] * t),
                          (float)(o[2] + d[2] * t)};
            double f = vs_density_at(buf, &acc, vs_vec3(p[0], p[1], p[2]));
            double w = (i == 0 || i == steps) ? 1.0 : (i % 2 ? 4.0 : 2.0);
            sum += w * f;
        }
        double reference = sum * tmax / steps / 3.0;
        if (reference > 1e-3)
            ++nonzero;
        if (fabs(tau - reference) > 2e-4 * reference + 1e-6)
            fail_msg("ray %d: march %.9g quadrature %.9g", ray, tau, reference);
    }
    assert_true(nonzero > 20);
    vdbs_volume_free(&volume);
}

/* Extremes stay finite and non-negative: optical depth per voxel from 1e-6 to 1e4,
 * lights of 1e-6 and 1e6 (linear in the light), a one-voxel grid. */
static void test_extremes(void **state)
{
    (void)state;
    const double h = 0.1;
    double m[3][4];
    scale_transform(h, m);
    vdbs_volume volume;
    make_block(6, m, &volume);
    const double down[3] = {0.2, -1.0, 0.1};
    const double sigmas[] = {1e-5, 1.0, 1e5};
    for (size_t s = 0; s < 3; ++s) {
        vdbs_scene lo, hi;
        sun_scene(&lo, sigmas[s], down, 1e-6);
        sun_scene(&hi, sigmas[s], down, 1e6);
        vdbs_scene_validate(&lo, NULL);
        vdbs_scene_validate(&hi, NULL);
        float *a = solve(&volume, &lo, 0);
        float *b = solve(&volume, &hi, 0);
        for (size_t v = 0; v < 3 * volume.coord_count; ++v) {
            assert_true(isfinite(a[v]) && a[v] >= 0.0f);
            assert_true(isfinite(b[v]) && b[v] >= 0.0f);
            if (a[v] > 1e-30f)
                assert_true(test_rel_diff(b[v], 1e12 * a[v]) < 1e-5);
        }
        free(a);
        free(b);
    }
    vdbs_volume_free(&volume);

    make_block(1, m, &volume);
    assert_int_equal((int)volume.coord_count, 27);
    vdbs_scene scene;
    sun_scene(&scene, 2.0, down, 1.0);
    float *r = solve(&volume, &scene, 0);
    for (size_t v = 0; v < 3 * volume.coord_count; ++v)
        assert_true(isfinite(r[v]) && r[v] >= 0.0f && r[v] <= 2.0f / (4.0 * PI) + 1e-7);
    free(r);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_block_normal_sun),
        cmocka_unit_test(test_block_rotated_nonuniform),
        cmocka_unit_test(test_point_light_homogeneous),
        cmocka_unit_test(test_sky_without_medium),
        cmocka_unit_test(test_sphere_directions_balanced),
        cmocka_unit_test(test_march_matches_quadrature),
        cmocka_unit_test(test_extremes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
