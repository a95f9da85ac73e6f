#include "testutil.h"

#include "vdbscatter/samples.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *test_data_path(const char *file)
{
    if (!VDBS_TEST_DATA_DIR[0]) {
        print_message("needs the external test data (%s): skipped\n", file);
        skip();
    }
    static char buf[8][4096];
    static int slot;
    char *out = buf[slot++ & 7];
    snprintf(out, 4096, "%s/%s", VDBS_TEST_DATA_DIR, file);
    return out;
}

const char *test_tmp_path(const char *file)
{
    static char buf[8][4096];
    static int slot;
    char *out = buf[slot++ & 7];
    snprintf(out, 4096, "%s/%s", VDBS_TEST_TMP_DIR, file);
    return out;
}

void test_truncated_copy(const char *from, const char *to, double keep)
{
    FILE *f = fopen(from, "rb");
    assert_non_null(f);
    static char bytes[1 << 17];
    size_t n = fread(bytes, 1, sizeof bytes, f);
    fclose(f);
    assert_true(n > 0 && n < sizeof bytes);
    f = fopen(to, "wb");
    assert_non_null(f);
    fwrite(bytes, 1, (size_t)(n * keep), f);
    fclose(f);
}

double test_rel_diff(double a, double b)
{
    double m = fmax(fabs(a), fabs(b));
    return m == 0.0 ? 0.0 : fabs(a - b) / m;
}

int test_compare_doubles(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

void test_add_sun_point_sky(vdbs_scene *scene)
{
    static const double sun_dir[3] = {0.3, -1.0, 0.2}, sun[3] = {3.0, 3.0, 3.0};
    static const double point_pos[3] = {0.5, 1.2, -0.3}, point[3] = {2.0, 1.0, 0.5};
    static const double sky[3] = {0.2, 0.3, 0.5};
    scene->light_count = 3;
    scene->lights[0].type = VDBS_LIGHT_SUN;
    memcpy(scene->lights[0].direction, sun_dir, sizeof sun_dir);
    memcpy(scene->lights[0].color, sun, sizeof sun);
    scene->lights[1].type = VDBS_LIGHT_POINT;
    memcpy(scene->lights[1].position, point_pos, sizeof point_pos);
    memcpy(scene->lights[1].color, point, sizeof point);
    scene->lights[2].type = VDBS_LIGHT_ENV;
    memcpy(scene->lights[2].color, sky, sizeof sky);
}

void test_load_ms_grids(const char *path, const double index_to_world[3][4], vdbs_lit_grids *ms)
{
    vdbio_lit *lit = NULL;
    vdbs_error err;
    if (vdbio_lit_open(path, &lit, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_lit_grids_load(lit, index_to_world, 0, ms, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbio_lit_close(lit);
    remove(path);
}

/* One runner per backend for the whole test program (a GL context is slow to create). */
static vdbs_runner *runners[3];

vdbs_runner *test_runner(vdbs_backend backend)
{
    if (!runners[backend]) {
        vdbs_runner_desc desc = {.backend = backend};
        vdbs_error err;
        if (vdbs_runner_create(&desc, &runners[backend], &err) != VDBS_OK)
            fail_msg("no %s runner: %s", backend == VDBS_BACKEND_GPU ? "GPU" : "C", err.message);
    }
    return runners[backend];
}

void test_runners_free(void)
{
    for (int b = 0; b < 3; ++b) {
        vdbs_runner_destroy(runners[b]);
        runners[b] = NULL;
    }
}

vdbs_status test_single_scatter(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, int sky, float *radiance, vdbs_error *err)
{
    vdbs_lights_desc desc = {.sky_ordinates = sky};
    vdbs_light_table lights;
    vdbs_status st = vdbs_lights_build(volume, scene, &desc, &lights, err);
    if (st != VDBS_OK)
        return st;
    st = vdbs_single_scatter(runner, volume, scene, &lights, radiance, NULL, err);
    vdbs_lights_free(&lights);
    return st;
}

double test_uniform(uint64_t *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) * 0x1.0p-53;
}

float *test_twin(const char *label, test_twin_fn run, const void *scenario, size_t n)
{
    float *out[2];
    const vdbs_backend backends[2] = {VDBS_BACKEND_CPU, VDBS_BACKEND_GPU};
    for (int b = 0; b < 2; ++b) {
        out[b] = calloc(n ? n : 1, sizeof(float));
        assert_non_null(out[b]);
        vdbs_error err;
        if (run(test_runner(backends[b]), scenario, out[b], &err) != VDBS_OK)
            fail_msg("%s (%s): %s", label, b ? "GPU" : "C", err.message);
    }
    size_t compared = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; ++i) {
        for (int b = 0; b < 2; ++b)
            if (!(isfinite(out[b][i]) && out[b][i] >= 0.0f))
                fail_msg("%s: value %zu is %g on the %s path", label, i, out[b][i],
                         b ? "GPU" : "C");
        if (fabs(out[0][i]) < 1e-30 && fabs(out[1][i]) < 1e-30)
            continue;
        double d = test_rel_diff(out[0][i], out[1][i]);
        worst = fmax(worst, d);
        if (d > 1e-5)
            fail_msg("%s: value %zu: C %.9g GLSL %.9g", label, i, out[0][i], out[1][i]);
        ++compared;
    }
    print_message("%s: compared %zu of %zu values, worst relative difference %.3g\n", label,
                  compared, n, worst);
    assert_true(compared > n / 2);
    free(out[1]);
    return out[0];
}

void test_write_lit(const char *path, const vdbs_volume *volume, const float *ms,
                    float *const l1[3])
{
    vdbio_vec3_grid grids[] = {
        {"radiance", ms}, {"ms", ms}, {"ms_l1x", l1[0]}, {"ms_l1y", l1[1]}, {"ms_l1z", l1[2]},
    };
    vdbio_write_request request = {0};
    request.density = volume->density;
    request.coords = volume->coords;
    request.coord_count = volume->coord_count;
    request.vec3_grids = grids;
    request.vec3_grid_count = 5;
    vdbs_error err;
    if (vdbio_write(path, NULL, &request, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

void test_sample_volume(const char *name, int res, unsigned seed, vdbs_volume *volume)
{
    vdbio_density *density = NULL;
    vdbs_error err;
    if (vdbs_sample_create(name, res, seed, &density, &err) != VDBS_OK ||
        vdbs_volume_from_density(density, volume, &err) != VDBS_OK)
        fail_msg("sample %s: %s", name, err.message);
}

void test_gauss_legendre(int n, double a, double b, double *x, double *w)
{
    const double pi = 3.14159265358979323846;
    for (int i = 0; i < n; ++i) {
        double z = cos(pi * (i + 0.75) / (n + 0.5)), pp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = 0.0;
            for (int k = 1; k <= n; ++k) {
                double p2 = p1;
                p1 = p0;
                p0 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p2) / k;
            }
            pp = n * (z * p0 - p1) / (z * z - 1.0);
            double dz = p0 / pp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = a + 0.5 * (b - a) * (1.0 - z);
        w[i] = (b - a) / ((1.0 - z * z) * pp * pp);
    }
}

void test_dense_volume(float *values, const int dims[3], const int origin[3],
                       const vdbio_transform *xf, vdbs_volume *volume)
{
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_density_from_dense(values, dims, origin, xf, "density", &density, &err),
                     VDBS_OK);
    free(values);
    assert_int_equal(vdbs_volume_from_density(density, volume, &err), VDBS_OK);
}
