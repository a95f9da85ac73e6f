/* The multiple-scattering field must not show the solver's coarse cells (docs/design.md
 * "Upsampling without seams"). First the seam measure itself (seams.h) on fields whose answer
 * is known, so that it cannot pass by detecting nothing: a smooth field has no peak at the cell
 * frequency, the same field reconstructed piecewise-linearly from samples at cell centres has
 * one, at integer and fractional cell sizes. Then coarse.c's kernels on a synthetic coarse
 * field over the cloud sample: trilinear shows the cells, both B-splines do not, all keep a
 * constant, and all reproduce a linear field where the bilateral factor is uniform. Then the
 * bar, ratio <= 1.5 on every axis for ms and each ms_l1 grid, for POP, FLD and SVD at quality
 * low on samples/cloud.json (test_seams_data: the Disney cloud, label "long"). */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "seams.h"
#include "seams_bake.h"
#include "vdbscatter/coarse.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/scene_file.h"

#define BAR 1.5
/* Lines that met enough medium on every axis (the fewest measured: 57, POP on the Disney
 * cloud across y, with 19 voxels per cell): the ratio is an average, not one line. */
#define MIN_LINES 40
/* What the positive controls must reach, clear of the bar: a synthetic field cut into cells
 * (measured 18 to 3000), and coarse.c's trilinear kernel over the cloud (measured 2.2 to 10:
 * the bilateral factor's fine detail stands beside the kinks). */
#define DETECT 4.0
#define DETECT_KERNEL 2.0
#define PI 3.14159265358979323846

/* A smooth test field: a broad blob times a ripple at a frequency that is no cell's. */
static double smooth_field(double x, double y, double z)
{
    const double r2 = (x - 30.0) * (x - 30.0) + (y - 34.0) * (y - 34.0) + (z - 29.0) * (z - 29.0);
    return exp(-r2 / (2.0 * 18.0 * 18.0)) * (1.0 + 0.3 * sin(0.11 * x + 0.07 * y - 0.05 * z));
}

/* The field on a 64^3 box inside a ball of radius 30: exact, or trilinear from its samples at
 * the centres of cells of `cell` voxels. */
static void synthetic_case(double cell, int trilinear, test_seams *out)
{
    const int n[3] = {64, 64, 64};
    const size_t total = 64 * 64 * 64;
    double *m = malloc(sizeof *m * total);
    unsigned char *inside = malloc(total);
    assert_true(m && inside);
    for (int k = 0; k < 64; ++k)
        for (int j = 0; j < 64; ++j)
            for (int i = 0; i < 64; ++i) {
                const size_t at = ((size_t)k * 64 + j) * 64 + i;
                const double p[3] = {i, j, k};
                const double r2 =
                    (i - 32.0) * (i - 32.0) + (j - 32.0) * (j - 32.0) + (k - 32.0) * (k - 32.0);
                inside[at] = r2 < 30.0 * 30.0;
                if (!trilinear) {
                    m[at] = smooth_field(p[0], p[1], p[2]);
                    continue;
                }
                double c0[3], t[3];
                for (int a = 0; a < 3; ++a) {
                    const double x = (p[a] + 0.5) / cell - 0.5;
                    c0[a] = floor(x);
                    t[a] = x - c0[a];
                }
                double v = 0.0;
                for (int c = 0; c < 8; ++c) {
                    double w = 1.0, q[3];
                    for (int a = 0; a < 3; ++a) {
                        const int bit = (c >> a) & 1;
                        w *= bit ? t[a] : 1.0 - t[a];
                        q[a] = (c0[a] + bit + 0.5) * cell - 0.5;
                    }
                    v += w * smooth_field(q[0], q[1], q[2]);
                }
                m[at] = v;
            }
    const double cells[3] = {cell, cell, cell};
    test_seams_dense(m, inside, n, cells, out);
    free(m);
    free(inside);
}

static void test_measure_detects(void **state)
{
    (void)state;
    const double cells[] = {4.0, 8.0, 5.3333333};
    for (int c = 0; c < 3; ++c) {
        test_seams smooth, cut;
        synthetic_case(cells[c], 0, &smooth);
        synthetic_case(cells[c], 1, &cut);
        for (int a = 0; a < 3; ++a) {
            print_message("cell %.2f voxels, axis %d: smooth %.3f, trilinear %.3f (%ld lines)\n",
                          cells[c], a, smooth.ratio[a], cut.ratio[a], cut.lines[a]);
            assert_true(smooth.lines[a] > 1000 && cut.lines[a] == smooth.lines[a]);
            assert_true(smooth.ratio[a] > 0.0 && smooth.ratio[a] <= BAR);
            assert_true(cut.ratio[a] >= DETECT);
        }
    }
}

static void load_cloud(vdbs_scene *scene, vdbs_volume *volume)
{
    vdbs_error err;
    if (vdbs_scene_load(VDBS_TEST_SAMPLES_DIR "/cloud.json", scene, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbio_read_options read = {0};
    if (vdbs_volume_load(scene->volume_file, &read, volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* A coarse field that changes over a few cells on every axis: wavelengths of 3.3, 3.5 and 3.1
 * cells, so that a C0 reconstruction kinks visibly on every cell plane. */
static double ripple(const vdbs_coarse_frame *f, const double w[3])
{
    const double wl[3] = {3.3, 3.5, 3.1};
    double v = 1.0;
    for (int a = 0; a < 3; ++a)
        v *= 1.5 + sin(2.0 * PI * (w[a] - f->origin[a]) / (wl[a] * f->h));
    return v;
}

/* coarse.c's kernels on a smooth field given at the cell centres of a 12-cell world frame. */
static void test_upsample_kernels(void **state)
{
    (void)state;
    vdbs_scene scene;
    vdbs_volume volume;
    load_cloud(&scene, &volume);
    vdbs_coarse_frame f;
    vdbs_coarse_world_frame(&volume, 12, 1, &f);
    const int64_t cells = vdbs_coarse_cells(&f);
    vdbs_medium_box box;
    vdbs_error err;
    int block = (int)floor(f.h / volume.mean_voxel_size);
    assert_int_equal(vdbs_medium_box_build(&volume, block, &box, &err), VDBS_OK);
    double *values = calloc((size_t)cells * VDBS_COARSE_WIDTH, sizeof *values);
    const size_t n = volume.coord_count;
    float *ms = malloc(sizeof *ms * 3 * n), *radiance = malloc(sizeof *radiance * 3 * n);
    float *l1[3] = {malloc(sizeof(float) * 3 * n), malloc(sizeof(float) * 3 * n),
                    malloc(sizeof(float) * 3 * n)};
    assert_true(values && ms && radiance && l1[0] && l1[1] && l1[2]);
    for (int field = 0; field < 2; ++field) {
        for (int64_t c = 0; c < cells; ++c) {
            double w[3];
            vdbs_coarse_cell_centre(&f, c, w);
            for (int v = 0; v < VDBS_COARSE_WIDTH; ++v)
                values[c * VDBS_COARSE_WIDTH + v] = field == 0 ? 0.25 : ripple(&f, w);
        }
        for (int k = 0; k < 3; ++k) {
            const vdbs_coarse_kernel kernels[3] = {VDBS_COARSE_BSPLINE, VDBS_COARSE_BSPLINE_INTERP,
                                                   VDBS_COARSE_TRILINEAR};
            const char *names[3] = {"B-spline", "interpolating B-spline", "trilinear"};
            const vdbs_coarse_kernel kernel = kernels[k];
            memset(ms, 0, sizeof *ms * 3 * n);
            memset(radiance, 0, sizeof *radiance * 3 * n);
            for (int a = 0; a < 3; ++a)
                memset(l1[a], 0, sizeof(float) * 3 * n);
            assert_int_equal(vdbs_coarse_upsample(&f, values, &volume, &box, 20.0, kernel, ms, l1,
                                                  radiance, &err),
                             VDBS_OK);
            if (field == 0) {
                /* The weights are renormalised: a constant stays that constant. */
                for (size_t v = 0; v < 3 * n; ++v) {
                    assert_float_equal(ms[v], 0.25f, 1e-6f);
                    assert_float_equal(l1[v % 3][v], 0.25f, 1e-6f);
                }
                continue;
            }
            test_seams s;
            test_seams_measure(&volume, ms, f.h, &s);
            for (int a = 0; a < 3; ++a)
                print_message("%s, axis %d: ratio %.3f at %.2f voxels per cell\n", names[k], a,
                              s.ratio[a], s.cell_voxels[a]);
            for (int a = 0; a < 3; ++a) {
                if (kernel == VDBS_COARSE_TRILINEAR)
                    assert_true(s.ratio[a] >= DETECT_KERNEL);
                else
                    assert_true(s.ratio[a] > 0.0 && s.ratio[a] <= BAR);
            }
        }
    }
    for (int a = 0; a < 3; ++a)
        free(l1[a]);
    free(ms);
    free(radiance);
    free(values);
    vdbs_medium_box_free(&box);
    vdbs_volume_free(&volume);
}

/* Every kernel reproduces a linear field where the bilateral factor is uniform: inside the
 * homogeneous cube sample, at voxels whose 4 x 4 x 4 cells (and the box filter around them)
 * lie inside the cube. The interpolating spline's prefilter leaves a linear sequence as it is
 * away from the grid's edges, and the B-spline reproduces linear functions. */
static void test_upsample_linear(void **state)
{
    (void)state;
    vdbs_volume volume;
    test_sample_volume("cube", 48, 1, &volume);
    vdbs_coarse_frame f;
    vdbs_coarse_world_frame(&volume, 8, 1, &f);
    const int64_t cells = vdbs_coarse_cells(&f);
    vdbs_medium_box box;
    vdbs_error err;
    assert_int_equal(
        vdbs_medium_box_build(&volume, (int)floor(f.h / volume.mean_voxel_size), &box, &err),
        VDBS_OK);
    double *values = malloc(sizeof *values * (size_t)cells * VDBS_COARSE_WIDTH);
    const size_t n = volume.coord_count;
    float *ms = malloc(sizeof *ms * 3 * n), *radiance = malloc(sizeof *radiance * 3 * n);
    float *l1[3] = {malloc(sizeof(float) * 3 * n), malloc(sizeof(float) * 3 * n),
                    malloc(sizeof(float) * 3 * n)};
    assert_true(values && ms && radiance && l1[0] && l1[1] && l1[2]);
    for (int64_t c = 0; c < cells; ++c) {
        double w[3];
        vdbs_coarse_cell_centre(&f, c, w);
        for (int v = 0; v < VDBS_COARSE_WIDTH; ++v)
            values[c * VDBS_COARSE_WIDTH + v] = 1.0 + 0.3 * (w[0] + 2.0 * w[1] - w[2]);
    }
    /* Half-size 0.6; the taps reach 2 cells from the voxel, the guide's box half a cell more. */
    const double inner = 0.6 - 2.5 * f.h - 2.0 * volume.mean_voxel_size;
    assert_true(inner > 2.0 * volume.mean_voxel_size);
    const vdbs_coarse_kernel kernels[3] = {VDBS_COARSE_BSPLINE, VDBS_COARSE_BSPLINE_INTERP,
                                           VDBS_COARSE_TRILINEAR};
    /* Float rounding; the interpolating spline's mirror boundaries bend a linear sequence
     * near the grid's edges, the bend decaying as 0.268 per cell inwards (measured 7.9e-4
     * here, 8 cells across). */
    const double tolerance[3] = {1e-5, 2e-3, 1e-5};
    for (int k = 0; k < 3; ++k) {
        memset(ms, 0, sizeof *ms * 3 * n);
        memset(radiance, 0, sizeof *radiance * 3 * n);
        for (int a = 0; a < 3; ++a)
            memset(l1[a], 0, sizeof(float) * 3 * n);
        assert_int_equal(vdbs_coarse_upsample(&f, values, &volume, &box, 4.0, kernels[k], ms, l1,
                                              radiance, &err),
                         VDBS_OK);
        int checked = 0;
        double worst = 0.0;
        for (size_t v = 0; v < n; ++v) {
            double w[3];
            vdbs_volume_voxel_point(&volume, v, w);
            if (fabs(w[0]) > inner || fabs(w[1]) > inner || fabs(w[2]) > inner)
                continue;
            const double expect = 1.0 + 0.3 * (w[0] + 2.0 * w[1] - w[2]);
            worst = fmax(worst, fabs(ms[3 * v] - expect) / expect);
            worst = fmax(worst, fabs(l1[2][3 * v + 2] - expect) / expect);
            ++checked;
        }
        print_message("kernel %d: linear field at %d voxels, worst relative error %.2e\n", k,
                      checked, worst);
        assert_true(checked >= 27);
        assert_true(worst <= tolerance[k]);
    }
    for (int a = 0; a < 3; ++a)
        free(l1[a]);
    free(ms);
    free(radiance);
    free(values);
    vdbs_medium_box_free(&box);
    vdbs_volume_free(&volume);
}

static void cloud_low(const char *method)
{
    vdbs_scene scene;
    vdbs_volume volume;
    load_cloud(&scene, &volume);
    snprintf(scene.method, sizeof scene.method, "%s", method);
    snprintf(scene.quality, sizeof scene.quality, "low");
    test_seams ms, l1[3];
    const double cell = test_seams_bake(&volume, &scene, &ms, l1);
    for (int a = 0; a < 3; ++a)
        print_message(
            "%s low, cloud sample, axis %d (%.2f voxels per cell, %ld lines): ms %.3f, ms_l1 "
            "%.3f %.3f %.3f\n",
            method, a, ms.cell_voxels[a], ms.lines[a], ms.ratio[a], l1[0].ratio[a], l1[1].ratio[a],
            l1[2].ratio[a]);
    for (int a = 0; a < 3; ++a) {
        assert_true(ms.lines[a] >= MIN_LINES);
        assert_true(ms.ratio[a] > 0.0 && ms.ratio[a] <= BAR);
        for (int m = 0; m < 3; ++m)
            assert_true(l1[m].ratio[a] > 0.0 && l1[m].ratio[a] <= BAR);
    }
    (void)cell;
    vdbs_volume_free(&volume);
}

static void test_pop_cloud(void **state)
{
    (void)state;
    cloud_low("pop");
}

static void test_fld_cloud(void **state)
{
    (void)state;
    cloud_low("fld");
}

static void test_svd_cloud(void **state)
{
    (void)state;
    cloud_low("svd");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_measure_detects), cmocka_unit_test(test_upsample_kernels),
        cmocka_unit_test(test_upsample_linear), cmocka_unit_test(test_pop_cloud),
        cmocka_unit_test(test_fld_cloud),       cmocka_unit_test(test_svd_cloud),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    test_runners_free();
    return rc;
}
