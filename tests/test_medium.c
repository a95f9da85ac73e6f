/* The medium module and the shared phase header: the majorant grid bounds sigma_t along
 * rays through the sample cloud and its DDA tiles each clipped ray; HG sampling (float and
 * double, shaders/vs_phase.h) against the exact CDF; the HG lobe identity (L, a) -> (L, a g).
 * Every check is deterministic: fixed rays and fixed quasi-random sample sequences. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/medium.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/volume.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "base/vdbs_math.h"
#include "vs_common.h"
#include "vs_phase.h"

/* ---- majorant grid and DDA ---- */

/* splitmix64: a fixed sequence of rays, the same on every run. */
static double next_unit(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

static void random_dir(uint64_t *state, double v[3])
{
    double z = 2.0 * next_unit(state) - 1.0, phi = 2.0 * VDBS_PI * next_unit(state);
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    v[0] = r * cos(phi);
    v[1] = r * sin(phi);
    v[2] = z;
}

typedef struct ray_stats {
    int rays_hit;
    int segments;
    double max_ratio; /* largest sigma_t / majorant seen */
} ray_stats;

/* Walks one ray: segments contiguous from t0, tiling [t0, t1]; sigma_t <= majorant inside
 * every segment and sigma_t = 0 on the parts of the ray outside the support box. */
static void check_ray(const vdbs_medium *medium, const vdbs_majorant_grid *grid, const double o[3],
                      const double d[3], double tmax, ray_stats *stats)
{
    const double dlen = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double t0, t1;
    int axis;
    int hit = vdbs_majorant_grid_clip(grid, o, d, tmax, &t0, &t1, &axis);
    if (!hit) {
        /* 200 index units: well beyond the 34-voxel box. */
        double far = fmin(200.0 / dlen, tmax);
        for (int k = 0; k < 64; ++k) {
            double t = far * (k + 0.5) / 64.0;
            double p[3] = {o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t};
            assert_true(vdbs_medium_sigma_t(medium, p) == 0.0);
        }
        return;
    }
    ++stats->rays_hit;
    assert_true(t0 >= 0.0 && t0 < t1);
    /* Outside the support box: nothing to bound. Keep a voxel's margin off the box faces,
     * where the sampled point is rounded to float. */
    for (int k = 0; k < 16; ++k) {
        double ta = t0 - (1.0 + k) / dlen, tb = t1 + (1.0 + 4.0 * k) / dlen;
        double pa[3] = {o[0] + d[0] * ta, o[1] + d[1] * ta, o[2] + d[2] * ta};
        double pb[3] = {o[0] + d[0] * tb, o[1] + d[1] * tb, o[2] + d[2] * tb};
        if (ta >= 0.0)
            assert_true(vdbs_medium_sigma_t(medium, pa) == 0.0);
        if (tmax == HUGE_VAL)
            assert_true(vdbs_medium_sigma_t(medium, pb) == 0.0);
    }

    vdbs_majorant_dda dda;
    vdbs_majorant_dda_init(&dda, grid, o, d, t0, t1);
    double ta, tb, maj, prev_end = t0, sum = 0.0;
    int n = 0;
    while (vdbs_majorant_dda_next(&dda, &ta, &tb, &maj)) {
        assert_true(ta == prev_end); /* contiguous, exactly */
        assert_true(tb >= ta);
        sum += tb - ta;
        prev_end = tb;
        ++n;
        assert_true(n < 1000);
        /* Points well inside the segment (short ones skipped): a point rounded to float
         * must stay in this cell, within 2e-6 voxels of where it was. */
        if ((tb - ta) * dlen < 1e-3)
            continue;
        for (int k = 0; k < 16; ++k) {
            double t = ta + (tb - ta) * (k + 0.5) / 16.0;
            double p[3] = {o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t};
            double sigma = vdbs_medium_sigma_t(medium, p);
            assert_true(sigma <= maj);
            if (maj > 0.0 && sigma / maj > stats->max_ratio)
                stats->max_ratio = sigma / maj;
        }
    }
    stats->segments += n;
    assert_true(n >= 1);
    /* The segments tile [t0, t1]: the last ends at t1 and the lengths add up to it. */
    double scale = fmax(1.0, t1);
    assert_true(fabs(prev_end - t1) <= 1e-12 * scale);
    assert_true(fabs(sum - (t1 - t0)) <= 1e-12 * scale);
}

static void test_majorant_bounds_cloud(void **state)
{
    (void)state;
    vdbio_density *density = NULL;
    vdbs_volume volume;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("cloud", 32, 3, &density, &err), VDBS_OK);
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 20.0;
    scene.albedo[0] = 0.9;
    scene.albedo[1] = 0.8;
    scene.albedo[2] = 0.7;
    scene.g = 0.6;
    vdbs_medium medium;
    vdbs_medium_init(&medium, &volume, &scene);
    assert_ptr_equal(medium.volume, &volume);
    assert_true(medium.density_scale == 20.0 && medium.g == 0.6 && medium.albedo[2] == 0.7);

    vdbs_majorant_grid grid;
    assert_int_equal(vdbs_majorant_grid_build(&medium, &grid, &err), VDBS_OK);
    assert_int_equal(grid.block, VDBS_MAJORANT_BLOCK);
    for (int a = 0; a < 3; ++a) {
        assert_true(grid.hi[a] > grid.lo[a]);
        assert_true(grid.dims[a] * grid.block >= grid.hi[a] - grid.lo[a]);
    }

    double centre[3], radius = 0.0;
    for (int a = 0; a < 3; ++a) {
        centre[a] = 0.5 * (grid.lo[a] + grid.hi[a]);
        radius += 0.25 * (grid.hi[a] - grid.lo[a]) * (grid.hi[a] - grid.lo[a]);
    }
    radius = sqrt(radius);

    ray_stats stats = {0, 0, 0.0};
    uint64_t rng = 12345;
    for (int r = 0; r < 400; ++r) {
        double o[3], d[3], u[3], target[3];
        random_dir(&rng, u);
        for (int a = 0; a < 3; ++a) {
            target[a] = grid.lo[a] + (grid.hi[a] - grid.lo[a]) * next_unit(&rng);
            o[a] = centre[a] + 1.5 * radius * u[a];
        }
        if (r % 4 == 1) /* start inside the box */
            for (int a = 0; a < 3; ++a)
                o[a] = grid.lo[a] + (grid.hi[a] - grid.lo[a]) * next_unit(&rng);
        double len = 0.0;
        for (int a = 0; a < 3; ++a) {
            d[a] = target[a] - o[a];
            len += d[a] * d[a];
        }
        len = sqrt(len);
        if (r % 4 == 1)
            random_dir(&rng, d);
        else
            for (int a = 0; a < 3; ++a)
                d[a] /= len;
        if (r % 8 == 3) /* axis-aligned: zero direction components */
            for (int a = 0; a < 3; ++a)
                d[a] = a == r / 8 % 3 ? (r % 16 == 3 ? -0.5 : 0.5) : 0.0;
        if (r % 8 == 3)
            for (int a = 0; a < 3; ++a)
                o[a] = a == r / 8 % 3 ? centre[a] - 2.0 * d[a] * radius : target[a];
        /* Non-unit lengths: t is in world units, d the index image of a unit step. */
        double s = 0.5 + 2.0 * next_unit(&rng);
        for (int a = 0; a < 3; ++a)
            d[a] *= s;
        double tmax = r % 5 == 2 ? 0.5 * radius / s : HUGE_VAL;
        check_ray(&medium, &grid, o, d, tmax, &stats);
    }
    assert_true(stats.rays_hit > 300);
    assert_true(stats.segments > 1500);
    /* Tight enough to be useful: somewhere the density reaches most of its bound. */
    assert_true(stats.max_ratio > 0.5);

    /* density_scale 0: an all-zero grid. */
    vdbs_majorant_grid zero;
    medium.density_scale = 0.0;
    assert_int_equal(vdbs_majorant_grid_build(&medium, &zero, &err), VDBS_OK);
    size_t cells = (size_t)zero.dims[0] * zero.dims[1] * zero.dims[2];
    for (size_t i = 0; i < cells; ++i)
        assert_true(zero.maj[i] == 0.0f);
    vdbs_majorant_grid_free(&zero);
    assert_null(zero.maj);

    vdbs_majorant_grid_free(&grid);
    vdbs_volume_free(&volume);
}

/* ---- HG sampling ---- */

#define HG_N 200000
#define HG_BINS 40

/* Exact CDF of mu for HG(g), without dividing by g: with s = sqrt(1 + g^2 - 2 g x),
 * P(mu <= x) = (1-g^2)/(2g) (1/s - 1/(1+g)) = (1-g)(1+x) / (s (1+g+s)). */
static double hg_cdf(double g, double x)
{
    double s = sqrt((1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - x));
    return (1.0 - g) * (1.0 + x) / (s * (1.0 + g + s));
}

/* P(1 - mu < y) = 1 - CDF(1 - y): in double its absolute error stays near 1e-16, far
 * below one sample in HG_N, even where it is tiny. */
static double hg_tail(double g, double y)
{
    return 1.0 - hg_cdf(g, 1.0 - y);
}

static int bin_linear(double mu)
{
    int b = (int)floor((mu + 1.0) * 0.5 * HG_BINS);
    return b < 0 ? 0 : b >= HG_BINS ? HG_BINS - 1 : b;
}

/* Logarithmic bins of 1 - mu from 1e-10 to 2 (the forward peak of g -> 1). */
static double log_edge(int b)
{
    return b <= 0 ? 0.0 : b >= HG_BINS ? 2.0 : 1e-10 * pow(2e10, (double)b / HG_BINS);
}

static int bin_log(double omm)
{
    if (!(omm > 1e-10))
        return 0;
    int b = (int)floor(HG_BINS * log(omm / 1e-10) / log(2e10));
    return b < 0 ? 0 : b >= HG_BINS ? HG_BINS - 1 : b;
}

static void test_hg_sample(void **state)
{
    (void)state;
    static const double gs[] = {-0.9, 0.0, 0.5, 0.99};
    for (size_t k = 0; k < sizeof gs / sizeof gs[0]; ++k) {
        const double g = gs[k];
        int hist_d[HG_BINS] = {0}, hist_f[HG_BINS] = {0};
        int log_d[HG_BINS] = {0}, log_f[HG_BINS] = {0};
        double sum_d = 0.0, sum_f = 0.0, prev_mu = -1.0;
        for (int i = 0; i < HG_N; ++i) {
            /* Midpoints: the mean is a deterministic quadrature of the inverse CDF. */
            double u = (i + 0.5) / HG_N;
            double mu, sin_theta;
            vs_hg_sample_d(g, u, &mu, &sin_theta);
            assert_true(mu >= -1.0 && mu <= 1.0);
            assert_true(fabs(sin_theta * sin_theta + mu * mu - 1.0) < 1e-12);
            assert_true(mu >= prev_mu); /* the inverse CDF increases */
            prev_mu = mu;
            assert_true(vdbs_reference_hg_sample(g, u) == mu);
            pnanovdb_vec3_t f = vs_hg_sample((float)g, (float)u);
            assert_true(f.x >= -1.0f && f.x <= 1.0f && f.y >= 0.0f && f.z >= 0.0f);
            assert_true(fabs((double)f.x - mu) < 1e-5);
            assert_true(fabs((double)f.y - sin_theta) < 2e-3);
            sum_d += mu;
            sum_f += f.x;
            ++hist_d[bin_linear(mu)];
            ++hist_f[bin_linear(f.x)];
            /* 1 - mu: the float sampler keeps it to full relative precision. */
            ++log_d[bin_log(1.0 - mu)];
            ++log_f[bin_log(f.z)];
        }
        /* mu(u) increases from -1 to 1, so on each cell of width h = 1/N the midpoint
         * rule errs by at most h times mu's rise over the cell: |error| <= 2/N in all, far
         * inside the 3 sigma = 3 sqrt((1-g^2)/(3N)) of random sampling (1e-5 vs 4e-3 at
         * g = 0, 5e-4 at g = 0.99). The float samples add their rounding. */
        double mean_d = sum_d / HG_N, mean_f = sum_f / HG_N;
        double three_sigma = 3.0 * sqrt((1.0 - g * g) / (3.0 * HG_N));
        assert_true(fabs(mean_d - g) <= 2.0 / HG_N + 1e-12);
        assert_true(fabs(mean_d - g) <= three_sigma);
        assert_true(fabs(mean_f - g) <= three_sigma);
        assert_true(fabs(mean_f - mean_d) <= 1e-6);
        /* With sorted u the count in a bin is N times its probability, +-1 (+-1 more for
         * an edge that a sample's rounding crosses); float differs from double only for
         * samples within its rounding of an edge. */
        for (int b = 0; b < HG_BINS; ++b) {
            double x0 = -1.0 + 2.0 * b / HG_BINS, x1 = -1.0 + 2.0 * (b + 1) / HG_BINS;
            double expect = HG_N * (hg_cdf(g, x1) - hg_cdf(g, x0));
            assert_true(fabs(hist_d[b] - expect) <= 2.0);
            assert_true(abs(hist_f[b] - hist_d[b]) <= 2);
            if (g > 0.0) {
                double y0 = log_edge(b), y1 = log_edge(b + 1);
                double p = HG_N * (hg_tail(g, y1) - hg_tail(g, y0));
                assert_true(fabs(log_d[b] - p) <= 2.0 + 1e-5 * p);
                assert_true(fabs(log_f[b] - p) <= 3.0 + 1e-4 * p);
            }
        }
    }
}

/* ---- lobe identity ---- */

/* A sphere quadrature: midpoints in mu = cos(theta) (equal areas) times midpoints in phi. */
#define LOBE_NMU 600
#define LOBE_NPHI 1200

static double hg_d(double g, const double w[3], const double d[3])
{
    double x = w[0] - d[0], y = w[1] - d[1], z = w[2] - d[2];
    return vs_hg_eval_d(g, 0.5 * (x * x + y * y + z * z));
}

static void test_hg_lobe_identity(void **state)
{
    (void)state;
    static const double pairs[][2] = {{0.6, 0.5}, {0.5, -0.6}, {-0.4, 0.7}, {0.0, 0.8}};
    const double axis[3] = {0.0, 0.0, 1.0};
    const double dw = 4.0 * VDBS_PI / ((double)LOBE_NMU * LOBE_NPHI);
    for (size_t k = 0; k < sizeof pairs / sizeof pairs[0]; ++k) {
        const double a = pairs[k][0], g = pairs[k][1];
        const float b = vs_hg_lobe_scatter((float)a, (float)g);
        assert_true(fabs(b - a * g) < 1e-7);
        for (int j = 0; j < 4; ++j) {
            /* Outgoing directions at 0, 50, 100 and 180 degrees from the lobe axis. */
            double th = (j < 3 ? 50.0 * j : 180.0) * VDBS_PI / 180.0, ph = 0.7 * j;
            double wo[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
            /* S(wo) = integral f_hg(w . d, a) HG_g(w . wo) dw, plus the moments of the
             * incident lobe (normalisation and first moment a d) on the same quadrature. */
            double s = 0.0, norm = 0.0, first[3] = {0.0, 0.0, 0.0};
            for (int i = 0; i < LOBE_NMU; ++i) {
                double mu = -1.0 + 2.0 * (i + 0.5) / LOBE_NMU, st = sqrt(1.0 - mu * mu);
                for (int p = 0; p < LOBE_NPHI; ++p) {
                    double phi = 2.0 * VDBS_PI * (p + 0.5) / LOBE_NPHI;
                    double w[3] = {st * cos(phi), st * sin(phi), mu};
                    double lobe = hg_d(a, w, axis);
                    s += lobe * hg_d(g, w, wo);
                    if (j == 0) {
                        norm += lobe;
                        for (int c = 0; c < 3; ++c)
                            first[c] += lobe * w[c];
                    }
                }
            }
            s *= dw;
            double one_minus = 0.5 * ((wo[0] - axis[0]) * (wo[0] - axis[0]) +
                                      (wo[1] - axis[1]) * (wo[1] - axis[1]) +
                                      (wo[2] - axis[2]) * (wo[2] - axis[2]));
            double expect = vs_hg(b, (float)one_minus);
            assert_true(test_rel_diff(s, expect) < 1e-3);
            if (j == 0) {
                /* Direction average L / 4pi and linear term 3 L a d / 4pi of a lobe (for
                 * the scattered one, a g in place of a). */
                assert_true(fabs(norm * dw - 1.0) < 1e-4);
                assert_true(fabs(first[0] * dw) < 1e-6 && fabs(first[1] * dw) < 1e-6);
                assert_true(fabs(first[2] * dw - a) < 1e-4);
            }
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_majorant_bounds_cloud),
        cmocka_unit_test(test_hg_sample),
        cmocka_unit_test(test_hg_lobe_identity),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
