/* Single scattering from light grids (bake --s1 grid) against closed forms and against the
 * exact per-voxel march (--s1 march, the oracle): a homogeneous block lit along an index
 * axis (samples on voxel centres, so the sweep's exact depths are looked up as they are),
 * a point light inside and above a homogeneous block (radial grids), a wide block lit at 30
 * and 60 degrees (depth linear two voxels inside every face where the
 * light entered through the lit face, so trilinear interpolation is exact up to rounding), and the
 * procedural cloud and smoke, the Disney cloud and a rotated, non-uniform block lit by a sun, a
 * point light and a sky (relative RMSE of radiance over voxels above 1e-3 of the maximum at most 1%
 * at the default oversampling, falling as it rises). */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

#include "vdbscatter/collision.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/single.h"
#include "vdbscatter/scene_file.h"

#define PI 3.14159265358979323846

static int teardown(void **state)
{
    (void)state;
    test_runners_free();
    return 0;
}

/* A homogeneous nx x ny x nz block of density 1 mapped to world by m (row-major 3x4). */
static void make_block(const int dims[3], const double m[3][4], vdbs_volume *volume)
{
    size_t count = (size_t)dims[0] * dims[1] * dims[2];
    float *values = malloc(sizeof(float) * count);
    for (size_t i = 0; i < count; ++i)
        values[i] = 1.0f;
    int origin[3] = {0, 0, 0};
    vdbio_transform xf;
    memcpy(xf.m, m, sizeof xf.m);
    test_dense_volume(values, dims, origin, &xf, volume);
}

/* S1 radiance by grids (oversample > 0) or by the exact march (oversample 0); sky grids at
 * the suns' spacing (the oversample's) unless sky_spacing says otherwise (lightgrid.h). */
static float *solve_stats(const vdbs_volume *volume, const vdbs_scene *scene, int sky,
                          int oversample, double sky_spacing, vdbs_s1_stats *stats)
{
    float *radiance = calloc(3 * (volume->coord_count ? volume->coord_count : 1), sizeof(float));
    vdbs_error err;
    vdbs_lights_desc ld = {.sky_ordinates = sky};
    vdbs_light_table lights;
    if (vdbs_lights_build(volume, scene, &ld, &lights, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_light_grid_desc gd = {oversample, 0, sky_spacing};
    vdbs_runner *runner = test_runner(VDBS_BACKEND_CPU);
    vdbs_status st =
        oversample > 0 ? vdbs_single_scatter_grids(runner, volume, scene, &lights, &gd, radiance,
                                                   stats, NULL, &err)
                       : vdbs_single_scatter(runner, volume, scene, &lights, radiance, NULL, &err);
    if (st != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_lights_free(&lights);
    return radiance;
}

static float *solve(const vdbs_volume *volume, const vdbs_scene *scene, int sky, int oversample)
{
    return solve_stats(volume, scene, sky, oversample, -1.0, NULL);
}

static void sun_scene(vdbs_scene *scene, double sigma_t, const double dir[3])
{
    vdbs_scene_init(scene);
    scene->density_scale = sigma_t;
    scene->light_count = 1;
    scene->lights[0].type = VDBS_LIGHT_SUN;
    memcpy(scene->lights[0].direction, dir, sizeof(double) * 3);
    scene->lights[0].color[0] = scene->lights[0].color[1] = scene->lights[0].color[2] = 1.0;
    vdbs_error err;
    assert_int_equal(vdbs_scene_validate(scene, &err), VDBS_OK);
}

/* A block of 24^3 voxels of 0.1, sun straight down: every voxel two or more from the sides
 * sees E exp(-tau) / 4pi with tau = (n - 0.5 - j) h sigma_t, to 1e-3 for tau <= 20. */
static void test_block_axis(void **state)
{
    (void)state;
    const int n = 24, dims[3] = {n, n, n};
    const double h = 0.1;
    double m[3][4] = {{h, 0, 0, 0}, {0, h, 0, 0}, {0, 0, h, 0}};
    vdbs_volume volume;
    make_block(dims, m, &volume);
    const double down[3] = {0.0, -1.0, 0.0};
    const double sigmas[] = {0.1, 1.0, 8.0};
    for (int f = 1; f <= 2; ++f)
        for (size_t s = 0; s < sizeof sigmas / sizeof *sigmas; ++s) {
            vdbs_scene scene;
            sun_scene(&scene, sigmas[s], down);
            float *radiance = solve(&volume, &scene, 0, f);
            int checked = 0;
            double worst = 0.0;
            for (size_t v = 0; v < volume.coord_count; ++v) {
                const int32_t *c = volume.coords + 3 * v;
                if (c[0] < 2 || c[0] > n - 3 || c[2] < 2 || c[2] > n - 3 || c[1] < 0 || c[1] >= n)
                    continue;
                double tau = (n - 0.5 - c[1]) * h * sigmas[s];
                if (tau > 20.0)
                    continue;
                double want = exp(-tau) / (4.0 * PI);
                worst = fmax(worst, test_rel_diff(radiance[3 * v], want));
                ++checked;
            }
            print_message("axis sun, F %d, sigma_t %g: %d voxels, worst relative error %.2e\n", f,
                          sigmas[s], checked, worst);
            assert_true(checked >= 20 * 20 * 10);
            assert_true(worst <= 1e-3);
            free(radiance);
        }
    vdbs_volume_free(&volume);
}

/* A wide block lit at 30 and 60 degrees from the vertical: voxels at least two voxels below
 * the lit face whose light entered through the lit face at least two voxels from its edges
 * see exp(-(n - 0.5 - j) h sigma_t / cos(theta)) / 4pi, to 2e-3 for tau <= 20. */
static void test_block_slanted(void **state)
{
    (void)state;
    const int dims[3] = {64, 16, 12}, n = dims[1];
    const double h = 0.1;
    double m[3][4] = {{h, 0, 0, 0}, {0, h, 0, 0}, {0, 0, h, 0}};
    vdbs_volume volume;
    make_block(dims, m, &volume);
    const double angles[2] = {30.0, 60.0};
    for (int f = 1; f <= 2; ++f)
        for (int a = 0; a < 2; ++a) {
            double theta = angles[a] * PI / 180.0;
            double dir[3] = {sin(theta), -cos(theta), 0.0};
            vdbs_scene scene;
            sun_scene(&scene, 1.5, dir);
            float *radiance = solve(&volume, &scene, 0, f);
            int checked = 0;
            double worst = 0.0;
            for (size_t v = 0; v < volume.coord_count; ++v) {
                const int32_t *c = volume.coords + 3 * v;
                /* Two or more voxels from every face: the interpolation's
                 * samples then lie where the depth is linear. */
                if (c[1] < 2 || c[1] > n - 3 || c[2] < 2 || c[2] > dims[2] - 3 || c[0] < 2 ||
                    c[0] > dims[0] - 3)
                    continue;
                /* Where the light ray crossed the lit face (index y = n - 0.5 + 0.5). */
                double rise = n - c[1];
                double x_entry = c[0] - rise * tan(theta);
                if (x_entry < 2.0 || x_entry > dims[0] - 3.0)
                    continue;
                double tau = (n - 0.5 - c[1]) * h * 1.5 / cos(theta);
                if (tau > 20.0)
                    continue;
                double want = exp(-tau) / (4.0 * PI);
                worst = fmax(worst, test_rel_diff(radiance[3 * v], want));
                ++checked;
            }
            print_message("%g degree sun, F %d: %d voxels, worst relative error %.2e\n", angles[a],
                          f, checked, worst);
            assert_true(checked >= 500);
            assert_true(worst <= 2e-3);
            free(radiance);
        }
    vdbs_volume_free(&volume);
}

/* A point light inside and above a homogeneous block of 32^3 voxels of 0.05 (sigma_t 4):
 * every voxel at least two voxels from the light and two inside the faces sees
 * I exp(-tau) / (4 pi r^2), tau = sigma_t r inside, and sigma_t r (y_top - y) / (y_light - y)
 * from above (the light enters through the top face, whose ramp integrates to half a voxel),
 * to 2e-3 (from above: at the default oversampling). */
/* S1 and the unscattered light's net flux (vdbs_s1_outputs) by grids. */
/* Every light's first collisions summed by the S1 pass's per-light callback (collision.h),
 * with S1 itself in radiance. */
static void collide(const vdbs_volume *volume, const vdbs_scene *scene, float *radiance,
                    double *total, double *flux)
{
    vdbs_error err;
    vdbs_lights_desc ld = {0};
    vdbs_light_table lights;
    if (vdbs_lights_build(volume, scene, &ld, &lights, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_collision_sum sum;
    if (vdbs_collision_sum_init(&sum, volume, &lights, scene->density_scale, 1, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_s1_outputs out = {radiance, NULL, vdbs_collision_sum_light, &sum, NULL};
    if (vdbs_single_scatter_grids_out(test_runner(VDBS_BACKEND_CPU), volume, scene, &lights, NULL,
                                      &out, NULL, NULL, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    memcpy(total, sum.total, sizeof *total * 3 * volume->coord_count);
    memcpy(flux, sum.flux, sizeof *flux * 9 * volume->coord_count);
    vdbs_collision_sum_free(&sum);
    vdbs_lights_free(&lights);
}

/* The first collisions' sums on a block 1.5 optically thick a voxel (the faces' average for
 * the sun, collision.c): a sun's flux is its collisions C times its direction of travel, a
 * point light's C times the unit vector away from the light, and both lights together the
 * sums (1e-7: the travel is kept as float). A point light keeps the point rule, sigma_t 4 pi S1
 * (float S1: 1e-5). */
static void test_collision_flux(void **state)
{
    (void)state;
    const int n = 16, dims[3] = {n, n, n};
    const double h = 0.1, sigma = 15.0;
    double m[3][4] = {{h, 0, 0, 0}, {0, h, 0, 0}, {0, 0, h, 0}};
    vdbs_volume volume;
    make_block(dims, m, &volume);
    const size_t count = volume.coord_count;
    const double light_at[3] = {0.75, 0.82, 0.71};
    vdbs_scene sun, point, both;
    const double dir[3] = {0.3, -1.0, 0.2};
    sun_scene(&sun, sigma, dir);
    vdbs_scene_init(&point);
    point.density_scale = sigma;
    point.light_count = 1;
    point.lights[0].type = VDBS_LIGHT_POINT;
    for (int a = 0; a < 3; ++a) {
        point.lights[0].position[a] = light_at[a];
        point.lights[0].color[a] = 2.0;
    }
    both = sun;
    both.lights[both.light_count++] = point.lights[0];
    float *rad[3];
    double *total[3], *flux[3];
    const vdbs_scene *scenes[3] = {&sun, &point, &both};
    for (int k = 0; k < 3; ++k) {
        rad[k] = calloc(3 * count, sizeof(float));
        total[k] = calloc(3 * count, sizeof(double));
        flux[k] = calloc(9 * count, sizeof(double));
        collide(&volume, scenes[k], rad[k], total[k], flux[k]);
    }
    const double *d = sun.lights[0].direction; /* unit after validate */
    double worst = 0.0, worst_point = 0.0;
    int checked = 0;
    for (size_t v = 0; v < count; ++v) {
        const int32_t *c = volume.coords + 3 * v;
        double away[3], r = 0.0;
        for (int a = 0; a < 3; ++a) {
            away[a] = c[a] * h - light_at[a];
            r += away[a] * away[a];
        }
        r = sqrt(r);
        const int inside = c[0] >= 0 && c[0] < n && c[1] >= 0 && c[1] < n && c[2] >= 0 && c[2] < n;
        for (int ch = 0; ch < 3; ++ch) {
            const size_t j = 3 * v + (size_t)ch;
            const double scale = fmax(total[0][j] + total[1][j], 1e-30);
            worst = fmax(worst, fabs(total[2][j] - total[0][j] - total[1][j]) / scale);
            const double want = inside ? sigma * 4.0 * PI * rad[1][j] : 0.0;
            worst_point = fmax(worst_point, fabs(total[1][j] - want) / fmax(want, 1e-30));
            for (int a = 0; r >= h && a < 3; ++a) {
                const size_t i = 9 * v + 3 * (size_t)a + (size_t)ch;
                worst = fmax(worst, fabs(flux[0][i] - total[0][j] * d[a]) / scale);
                worst = fmax(worst, fabs(flux[1][i] - total[1][j] * away[a] / r) / scale);
                worst = fmax(worst, fabs(flux[2][i] - flux[0][i] - flux[1][i]) / scale);
            }
        }
        ++checked;
    }
    print_message("collisions: %d voxels, sums worst %.2e, point light against sigma_t 4 pi S1 "
                  "%.2e\n",
                  checked, worst, worst_point);
    assert_true(checked > 4000);
    assert_true(worst <= 1e-7);
    assert_true(worst_point <= 1e-5);
    for (int k = 0; k < 3; ++k) {
        free(rad[k]);
        free(total[k]);
        free(flux[k]);
    }
    vdbs_volume_free(&volume);
}

/* A delta-M medium's scaled beam (k = 1 - f albedo, SVD at g 0.999: about 0.015) through a
 * block 1e4 optically thick a voxel. The light grids stop marching past VS_TAU_LIMIT, so the
 * depths inside stand for any larger one: the scaled beam reaches no voxel two voxels in
 * (exp(-0.015 x 2e4)), and what it scatters in all is at most the irradiance times the
 * support box's projected area. Before the limit was kept, depths of about 100-250 read there
 * put a quarter of the face's collisions two voxels deep, and SVD absorbed 5x the light that
 * entered (docs/robustness.md "Extremes"). */
typedef struct scaled_beam {
    const vdbs_volume *volume;
    const vdbs_light_table *lights;
    vdbs_voxel_faces faces;
    double *scratch, *rate;
    double density_scale;
} scaled_beam;

static const double SCALED_K = 0.015;

static void scaled_collisions(void *user, int light, const float *depth)
{
    scaled_beam *b = user;
    const double k[3] = {SCALED_K, SCALED_K, SCALED_K};
    vdbs_first_collisions(b->volume, &b->faces, b->lights, light, depth, b->density_scale, k,
                          b->scratch, b->rate, NULL);
}

static void test_scaled_beam_past_limit(void **state)
{
    (void)state;
    assert_true(vdbs_beam_transmittance(SCALED_K, VS_TAU_LIMIT) == 0.0);
    assert_true(vdbs_beam_transmittance(1.0, VS_TAU_LIMIT * 4.0f) == 0.0);
    assert_true(test_rel_diff(vdbs_beam_transmittance(SCALED_K, 0.99f * VS_TAU_LIMIT),
                              exp(-SCALED_K * 0.99 * VS_TAU_LIMIT)) < 1e-12);
    const int n = 8, dims[3] = {n, n, n};
    const double h = 0.1, sigma = 1e4 / h;
    double m[3][4] = {{h, 0, 0, 0}, {0, h, 0, 0}, {0, 0, h, 0}};
    vdbs_volume volume;
    make_block(dims, m, &volume);
    const double dir[3] = {0.3, -1.0, 0.2};
    vdbs_scene scene;
    sun_scene(&scene, sigma, dir);
    vdbs_error err;
    vdbs_lights_desc ld = {0};
    vdbs_light_table lights;
    if (vdbs_lights_build(&volume, &scene, &ld, &lights, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    const size_t count = volume.coord_count;
    scaled_beam b = {&volume, &lights, {0}, NULL, NULL, sigma};
    assert_int_equal(vdbs_voxel_faces_build(&volume, &b.faces, &err), VDBS_OK);
    b.scratch = malloc(sizeof *b.scratch * VDBS_COLLISION_SCRATCH * count);
    b.rate = calloc(3 * count, sizeof *b.rate);
    float *radiance = calloc(3 * count, sizeof *radiance);
    vdbs_s1_outputs out = {radiance, NULL, scaled_collisions, &b, NULL};
    if (vdbs_single_scatter_grids_out(test_runner(VDBS_BACKEND_CPU), &volume, &scene, &lights, NULL,
                                      &out, NULL, NULL, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    double lo[3], hi[3], total = 0.0, deep = 0.0;
    vdbs_volume_support_bounds(&volume, lo, hi);
    const double *d = scene.lights[0].direction; /* unit after validate */
    const double entering = fabs(d[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) +
                            fabs(d[1]) * (hi[0] - lo[0]) * (hi[2] - lo[2]) +
                            fabs(d[2]) * (hi[0] - lo[0]) * (hi[1] - lo[1]);
    for (size_t v = 0; v < count; ++v) {
        const int32_t *c = volume.coords + 3 * v;
        total += b.rate[3 * v] * h * h * h;
        if (c[0] >= 2 && c[0] < n - 2 && c[1] >= 2 && c[1] < n - 2 && c[2] >= 2 && c[2] < n - 2)
            deep = fmax(deep, b.rate[3 * v]);
    }
    print_message("scaled beam k %g: scattered %.4g of at most %.4g entering, deepest rate %.3g\n",
                  SCALED_K, total, entering, deep);
    assert_true(total > 0.0 && total <= entering * (1.0 + 1e-6));
    assert_true(deep <= 1e-30);
    free(radiance);
    free(b.rate);
    free(b.scratch);
    vdbs_voxel_faces_free(&b.faces);
    vdbs_lights_free(&lights);
    vdbs_volume_free(&volume);
}

static void test_point_light_radial(void **state)
{
    (void)state;
    const int n = 32, dims[3] = {n, n, n};
    const double h = 0.05, sigma = 4.0;
    double m[3][4] = {{h, 0, 0, -1.0}, {0, h, 0, 0}, {0, 0, h, 0}};
    vdbs_volume volume;
    make_block(dims, m, &volume);
    const double inside[3] = {15.5, 15.25, 16.0}, above[3] = {16.2, 40.0, 15.7};
    for (int f = 1; f <= 2; ++f)
        for (int where = 0; where < 2; ++where) {
            const double *light = where ? above : inside;
            vdbs_scene scene;
            vdbs_scene_init(&scene);
            scene.density_scale = sigma;
            scene.light_count = 1;
            scene.lights[0].type = VDBS_LIGHT_POINT;
            for (int a = 0; a < 3; ++a) {
                scene.lights[0].position[a] = light[a] * h + m[a][3];
                scene.lights[0].color[a] = 7.0;
            }
            float *radiance = solve(&volume, &scene, 0, f);
            int checked = 0;
            double worst = 0.0;
            for (size_t v = 0; v < volume.coord_count; ++v) {
                const int32_t *c = volume.coords + 3 * v;
                int interior = 1;
                for (int a = 0; a < 3; ++a)
                    interior &= c[a] >= 2 && c[a] <= n - 3;
                double d[3] = {(c[0] - light[0]) * h, (c[1] - light[1]) * h, (c[2] - light[2]) * h};
                double r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                if (!interior || r < 2.0 * h)
                    continue;
                double path = r;
                if (where) {
                    /* Through the top face (index y = n - 0.5 carries the ramp's half voxel). */
                    double s = (n - 0.5 - c[1]) / (light[1] - c[1]);
                    double xe = c[0] + s * (light[0] - c[0]), ze = c[2] + s * (light[2] - c[2]);
                    if (xe < 2.0 || xe > n - 3.0 || ze < 2.0 || ze > n - 3.0)
                        continue;
                    path = r * s;
                }
                double want = 7.0 * exp(-sigma * path) / (4.0 * PI * r * r);
                worst = fmax(worst, test_rel_diff(radiance[3 * v], want));
                ++checked;
            }
            print_message("point light %s, F %d: %d voxels, worst relative error %.2e\n",
                          where ? "above" : "inside", f, checked, worst);
            assert_true(checked >= 1000);
            /* Inside, depth is sigma_t r on every shell: exact. From above it bends with the
             * direction; the default oversampling keeps it to the same bar. */
            if (!where || f >= VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE)
                assert_true(worst <= 2e-3);
            free(radiance);
        }
    vdbs_volume_free(&volume);
}

/* Relative RMSE of a against the reference b over the values above 1e-3 of b's maximum. */
static double relrmse(const float *a, const float *b, size_t n)
{
    double peak = 0.0;
    for (size_t i = 0; i < n; ++i)
        peak = fmax(peak, b[i]);
    double num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; ++i) {
        if (!(b[i] > 1e-3 * peak))
            continue;
        num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
        den += (double)b[i] * b[i];
    }
    return den > 0.0 ? sqrt(num / den) : 0.0;
}

static void lit_scene(vdbs_scene *scene, const vdbs_volume *volume, double density_scale)
{
    vdbs_scene_init(scene);
    scene->density_scale = density_scale;
    test_add_sun_point_sky(scene);
    /* The shared point light sits where the sample volumes are; move it into this one. */
    double centre[3], idx[3];
    for (int a = 0; a < 3; ++a)
        idx[a] = 0.5 * (volume->info.bbox_min[a] + volume->info.bbox_max[a]);
    vdbs_volume_world_point(volume, idx, centre);
    for (int i = 0; i < scene->light_count; ++i)
        if (scene->lights[i].type == VDBS_LIGHT_POINT)
            memcpy(scene->lights[i].position, centre, sizeof centre);
    vdbs_error err;
    assert_int_equal(vdbs_scene_validate(scene, &err), VDBS_OK);
}

/* Grid against march at oversample 1 up to max_oversample: at most 1% at the default, falling
 * as the oversampling rises. */
static void agree(const char *label, const vdbs_volume *volume, double density_scale, int sky,
                  int max_oversample)
{
    vdbs_scene scene;
    lit_scene(&scene, volume, density_scale);
    size_t n = 3 * volume->coord_count;
    float *exact = solve(volume, &scene, sky, 0);
    double e[4] = {0.0, 0.0, 0.0, 0.0};
    for (int f = 1; f <= max_oversample; ++f) {
        float *grid = solve(volume, &scene, sky, f);
        e[f] = relrmse(grid, exact, n);
        free(grid);
    }
    for (int f = 1; f <= max_oversample; ++f)
        print_message("%s: relative RMSE against the march at F %d: %.3e\n", label, f, e[f]);
    assert_true(e[VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE] <= 0.01);
    for (int f = 2; f <= max_oversample; ++f)
        assert_true(e[f] < e[f - 1]);
    free(exact);
}

static void test_agreement_samples(void **state)
{
    (void)state;
    const char *names[2] = {"cloud", "smoke"};
    for (int s = 0; s < 2; ++s) {
        vdbs_volume volume;
        test_sample_volume(names[s], 40, 7, &volume);
        agree(names[s], &volume, 12.0, 16, 3);
        vdbs_volume_free(&volume);
    }
}

static void test_agreement_disney_cloud(void **state)
{
    (void)state;
#if defined(__SANITIZE_ADDRESS__)
    /* The samples' agreement runs the same code under the sanitizers; this march, at 6x the
     * cost there, was the sanitized pass's longest test. */
    skip();
#endif
    vdbs_volume volume;
    vdbs_error err;
    vdbio_read_options read = {0};
    if (vdbs_volume_load(test_data_path("wdas_cloud_sixteenth.vdb"), &read, &volume, &err) !=
        VDBS_OK)
        fail_msg("%s", err.message);
    /* F 1 and 2 only: this is the suite's largest march (504k voxels); F 3 is in
     * bench/RESULTS.md. The error depends on the lighting: with 4
     * sky directions 0.76%, with 2 1.03%, with the default 64 0.46% (bench); the sun
     * alone 0.84%. */
    agree("wdas_cloud_sixteenth at 0.2", &volume, 0.2, 4, 2);
    vdbs_volume_free(&volume);
}

/* Sky grids sized by the sky's share of the light (the default rule, lightgrid.h) on the
 * bundled cloud sample (samples/cloud.json: density 20, a sun of 3 and a 64-direction sky) at
 * the default oversampling: with samples/cloud.json's sky (59% of the light) the sky keeps the
 * sun's spacing and S1 is within 0.5% of the march; with a sky a tenth as bright (13%) its
 * grids are coarser (a sixth of the cells) and add at most 0.15% to the error. */
static void test_sky_sizing_cloud_sample(void **state)
{
    (void)state;
    vdbs_volume volume;
    vdbs_error err;
    vdbio_read_options read = {0};
    if (vdbs_volume_load(VDBS_TEST_SAMPLES_DIR "/cloud.vdb", &read, &volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    for (int dim = 0; dim < 2; ++dim) {
        vdbs_scene scene;
        vdbs_scene_init(&scene);
        scene.density_scale = 20.0;
        scene.light_count = 2;
        scene.lights[0].type = VDBS_LIGHT_SUN;
        const double dir[3] = {0.3, -1.0, 0.2}, sun[3] = {3.0, 2.9, 2.7};
        const double sky[3] = {0.2, 0.3, 0.5}, f = dim ? 0.1 : 1.0;
        memcpy(scene.lights[0].direction, dir, sizeof dir);
        memcpy(scene.lights[0].color, sun, sizeof sun);
        scene.lights[1].type = VDBS_LIGHT_ENV;
        for (int c = 0; c < 3; ++c)
            scene.lights[1].color[c] = f * sky[c];
        assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
        size_t n = 3 * volume.coord_count;
        float *exact = solve(&volume, &scene, 64, 0);
        vdbs_s1_stats stats, same;
        float *sized =
            solve_stats(&volume, &scene, 64, VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE, 0.0, &stats);
        float *fine =
            solve_stats(&volume, &scene, 64, VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE, -1.0, &same);
        double e = relrmse(sized, exact, n), e_fine = relrmse(fine, exact, n);
        const vdbs_s1_kind_stats *su = &stats.kinds[VDBS_S1_SUN], *k = &stats.kinds[VDBS_S1_SKY];
        print_message("cloud sample, sun + 64 sky x %g: sky spacing %.3g to %.3g (sun %.3g), "
                      "%lld cells (%lld at the sun's), relative RMSE %.3e (%.3e at the sun's)\n",
                      f, k->grids.spacing_min, k->grids.spacing_max, su->grids.spacing_min,
                      (long long)stats.grids.cells, (long long)same.grids.cells, e, e_fine);
        assert_int_equal(su->lights, 1);
        assert_int_equal(k->lights, 64);
        assert_int_equal(stats.kinds[VDBS_S1_POINT].lights, 0);
        if (dim) {
            /* The sun's own error is 0.49% here: the sizing adds at most 0.15% (lightgrid.h). */
            assert_true(k->grids.spacing_min > 1.5 * su->grids.spacing_max);
            assert_true(stats.grids.cells * 3 < same.grids.cells);
            assert_true(e <= e_fine + 0.0015);
        } else {
            assert_true(k->grids.spacing_max == su->grids.spacing_max);
            assert_true(e <= 0.005);
        }
        free(exact);
        free(sized);
        free(fine);
    }
    vdbs_volume_free(&volume);
}

/* The rotated, non-uniform block of test_single.c: samples no longer on voxel centres. */
static void test_agreement_rotated(void **state)
{
    (void)state;
    const int dims[3] = {20, 20, 20};
    const double c = cos(0.7), s = sin(0.7), c2 = cos(-0.4), s2 = sin(-0.4);
    const double scale[3] = {0.07, 0.13, 0.05};
    double r[3][3] = {{c, -s * c2, s * s2}, {s, c * c2, -c * s2}, {0.0, s2, c2}};
    double m[3][4];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            m[i][j] = r[i][j] * scale[j];
        m[i][3] = 0.3 * (i + 1);
    }
    vdbs_volume volume;
    make_block(dims, m, &volume);
    agree("rotated non-uniform block", &volume, 5.0, 16, 3);
    vdbs_volume_free(&volume);
}

/* Extremes (docs/design.md): optical thickness 1e-5 to 1e5 per unit, lights of 1e-6 and 1e6, a
 * one-voxel grid, an empty grid and density scale 0: finite, non-negative, linear in the
 * lights, never above the unattenuated light, a point light inside and outside. */
static void test_extremes(void **state)
{
    (void)state;
    const double h = 0.1;
    double m[3][4] = {{h, 0, 0, 0}, {0, h, 0, 0}, {0, 0, h, 0}};
    const int six[3] = {6, 6, 6}, one[3] = {1, 1, 1};
    const double sigmas[] = {0.0, 1e-5, 1.0, 1e5};
    for (int size = 0; size < 2; ++size) {
        vdbs_volume volume;
        make_block(size ? one : six, m, &volume);
        for (size_t k = 0; k < sizeof sigmas / sizeof *sigmas; ++k) {
            float *r[2];
            for (int b = 0; b < 2; ++b) {
                vdbs_scene scene;
                vdbs_scene_init(&scene);
                scene.density_scale = sigmas[k];
                test_add_sun_point_sky(&scene);
                for (int i = 0; i < scene.light_count; ++i)
                    for (int c = 0; c < 3; ++c)
                        scene.lights[i].color[c] *= b ? 1e6 : 1e-6;
                vdbs_error err;
                assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
                r[b] = solve(&volume, &scene, 16, 2);
            }
            for (size_t v = 0; v < 3 * volume.coord_count; ++v) {
                assert_true(isfinite(r[0][v]) && r[0][v] >= 0.0f);
                assert_true(isfinite(r[1][v]) && r[1][v] >= 0.0f);
                if (r[0][v] > 1e-30f)
                    assert_true(test_rel_diff(r[1][v], 1e12 * r[0][v]) < 1e-5);
            }
            free(r[0]);
            free(r[1]);
        }
        vdbs_volume_free(&volume);
    }
    /* An empty grid: nothing to light, no error. */
    float zero = 0.0f;
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_density_from_dense(&zero, one, NULL, NULL, NULL, &density, &err),
                     VDBS_OK);
    vdbs_volume empty;
    assert_int_equal(vdbs_volume_from_density(density, &empty, &err), VDBS_OK);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    test_add_sun_point_sky(&scene);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    free(solve(&empty, &scene, 16, 2));
    vdbs_volume_free(&empty);
}

/* Empty space costs nothing: columns that meet no density store nothing, and a column
 * stores only the stretch where its depth changes. */
static void test_sparse_columns(void **state)
{
    (void)state;
    vdbs_volume volume;
    test_sample_volume("cloud", 40, 7, &volume);
    vdbs_error err;
    const double travel[3] = {0.3, -1.0, 0.2};
    vdbs_scene scene;
    sun_scene(&scene, 12.0, travel);
    vdbs_light_table lights;
    vdbs_lights_desc ld = {0};
    assert_int_equal(vdbs_lights_build(&volume, &scene, &ld, &lights, &err), VDBS_OK);
    vdbs_light_grids grids;
    assert_int_equal(vdbs_light_grids_build(test_runner(VDBS_BACKEND_CPU), &volume, &scene, &lights,
                                            0, 1, NULL, &grids, &err),
                     VDBS_OK);
    int n[3];
    vdbs_light_grids_shape(&grids, 0, n);
    const vdbs_light_grid_stats *s = &grids.stats;
    print_message("cloud 40^3: %dx%dx%d samples, %lld of %lld columns empty, %lld samples "
                  "stored (%.1f%%)\n",
                  n[0], n[1], n[2], (long long)s->columns_empty, (long long)s->columns,
                  (long long)s->stored, 100.0 * (double)s->stored / (double)s->cells);
    assert_int_equal(s->columns, (int64_t)n[0] * n[1]);
    assert_int_equal(s->cells, s->columns * n[2]);
    assert_true(s->columns_empty > 0 && s->columns_empty < s->columns);
    assert_true(s->stored < s->cells / 2);
    /* Upstream of everything the depth is 0; a point far downstream sees its column's. */
    double p[3] = {-100 * travel[0], -100 * travel[1], -100 * travel[2]}, index[3];
    vdbs_volume_index_point(&volume, p, index);
    assert_true(vdbs_light_grids_depth(&grids, 0, index) == 0.0f);
    vdbs_light_grids_free(&grids);
    vdbs_lights_free(&lights);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_block_axis),
        cmocka_unit_test(test_block_slanted),
        cmocka_unit_test(test_scaled_beam_past_limit),
        cmocka_unit_test(test_point_light_radial),
        cmocka_unit_test(test_collision_flux),
        cmocka_unit_test(test_agreement_samples),
        cmocka_unit_test(test_agreement_disney_cloud),
        cmocka_unit_test(test_agreement_rotated),
        cmocka_unit_test(test_extremes),
        cmocka_unit_test(test_sparse_columns),
        cmocka_unit_test(test_sky_sizing_cloud_sample),
    };
    return cmocka_run_group_tests(tests, NULL, teardown);
}
