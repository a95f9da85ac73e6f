/* The homogeneous-fog module (vdbscatter/render/fog.c, shaders/vs_fog.h): the closed-form
 * point-light spans against the brute-force quadrature of Biri's Eq. 3 over whole pinhole images
 * (camera inside the fog looking at the light, outside a fog box, with the light behind it, far
 * away), for g = 0, 0.6 and -0.6; span additivity (the shadowed sum); the sun span against its own
 * quadrature; the surface term against a direct hemisphere integration of Eq. 8 with
 * d = infinity; Biri's Gamma against Eq. 6; the build's input checks. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/fog.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "base/vdbs_math.h"
#include "vs_common.h"
#include "vs_phase.h"

#define N_G 3
static const double G_VALUES[N_G] = {0.0, 0.6, -0.6};
static vdbs_fog fogs[N_G];

#define SIGMA_T 0.5
#define ALBEDO 0.8
#define IMAGE_W 64
#define IMAGE_H 48

static int setup(void **state)
{
    (void)state;
    for (int k = 0; k < N_G; ++k) {
        vdbs_fog_desc desc = {0};
        desc.sigma_t = SIGMA_T;
        desc.albedo = ALBEDO;
        desc.g = G_VALUES[k];
        vdbs_error err;
        if (vdbs_fog_build(&desc, &fogs[k], &err) != VDBS_OK) {
            print_error("%s\n", err.message);
            return -1;
        }
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    for (int k = 0; k < N_G; ++k)
        vdbs_fog_free(&fogs[k]);
    return 0;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void normalize3(double v[3])
{
    double n = sqrt(dot3(v, v));
    for (int i = 0; i < 3; ++i)
        v[i] /= n;
}

/* The ray through pixel (x, y) of a 60-degree (vertical) pinhole camera at eye looking at
 * target, up +Y (docs/design.md's camera: right = forward x up, row 0 at the top). */
static void pinhole_ray(const double eye[3], const double target[3], int x, int y, double d[3])
{
    double f[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
    normalize3(f);
    double up[3] = {0.0, 1.0, 0.0};
    double r[3] = {f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2],
                   f[0] * up[1] - f[1] * up[0]};
    normalize3(r);
    double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    double th = tan(0.5 * 60.0 * VDBS_PI / 180.0);
    double px = (2.0 * (x + 0.5) / IMAGE_W - 1.0) * th * IMAGE_W / IMAGE_H;
    double py = (1.0 - 2.0 * (y + 0.5) / IMAGE_H) * th;
    for (int i = 0; i < 3; ++i)
        d[i] = f[i] + px * r[i] + py * u[i];
    normalize3(d);
}

/* Clips o + s d to the box [lo, hi]: [*s0, *s1]; 0 when they miss. */
static int clip_box(const double o[3], const double d[3], const double lo[3], const double hi[3],
                    double *s0, double *s1)
{
    double a = 0.0, b = INFINITY;
    for (int i = 0; i < 3; ++i) {
        if (d[i] == 0.0) {
            if (o[i] < lo[i] || o[i] > hi[i])
                return 0;
            continue;
        }
        double ta = (lo[i] - o[i]) / d[i], tb = (hi[i] - o[i]) / d[i];
        a = fmax(a, fmin(ta, tb));
        b = fmin(b, fmax(ta, tb));
    }
    *s0 = a;
    *s1 = b;
    return b > a;
}

/* ---- the point light over pinhole images ---- */

/* lambda at the Gamma table's third row (rows are uniform in sqrt(lambda)). */
static double lambda_two_rows(const vdbs_fog *fog)
{
    double x = 2.0 / (fog->desc.n_lambda - 1);
    return fog->desc.lambda_max * x * x;
}

typedef struct camera_case {
    const char *name;
    double eye[3], target[3];
    int fog_box; /* 1: fog only in the box [-4, 4]^3, else everywhere */
} camera_case;

static const camera_case CAMERAS[] = {
    {"inside, facing the light", {0.4, 0.7, 6.0}, {0.0, 0.0, 0.0}, 0},
    {"outside the fog box", {1.2, 2.0, 9.0}, {0.0, 0.0, 0.0}, 1},
    {"light behind the camera", {0.3, 0.2, 2.0}, {0.5, 0.0, 9.0}, 0},
    {"far, light off-centre", {-6.0, 3.0, 18.0}, {1.5, -1.0, 0.0}, 0},
    {"beside the light", {1.2, 0.0, 0.5}, {1.0, 0.3, -5.0}, 0},
};
#define N_CAMERAS ((int)(sizeof CAMERAS / sizeof CAMERAS[0]))

static void test_point_image(void **state)
{
    (void)state;
    const double light[3] = {0.0, 0.0, 0.0}, intensity = 3.0;
    const double box_lo[3] = {-4.0, -4.0, -4.0}, box_hi[3] = {4.0, 4.0, 4.0};
    for (int k = 0; k < N_G; ++k) {
        const vdbs_fog *fog = &fogs[k];
        /* Rays closer to the light than two table rows in lambda = sigma_t h are exempt. */
        const double lambda_min = lambda_two_rows(fog);
        double worst_all = 0.0;
        for (int c = 0; c < N_CAMERAS; ++c) {
            const camera_case *cam = &CAMERAS[c];
            double worst = 0.0;
            int compared = 0, exempt = 0;
#pragma omp parallel for reduction(max : worst) reduction(+ : compared, exempt) schedule(dynamic)
            for (int p = 0; p < IMAGE_W * IMAGE_H; ++p) {
                double d[3];
                pinhole_ray(cam->eye, cam->target, p % IMAGE_W, p / IMAGE_W, d);
                double s_enter = 0.0, s0 = 0.0, s1 = INFINITY;
                if (cam->fog_box && !clip_box(cam->eye, d, box_lo, box_hi, &s_enter, &s1))
                    continue;
                s0 = s_enter;
                double m[3] = {light[0] - cam->eye[0], light[1] - cam->eye[1],
                               light[2] - cam->eye[2]};
                double t = dot3(m, d), h = sqrt(fmax(0.0, dot3(m, m) - t * t));
                if (SIGMA_T * h < lambda_min) {
                    exempt++;
                    continue;
                }
                double want = vdbs_fog_point_march(&fog->desc, cam->eye, d, light, intensity,
                                                   s_enter, s0, s1);
                double got = vdbs_fog_point_span(fog, cam->eye, d, light, intensity, s_enter, s0,
                                                 isinf(s1) ? 1e30 : s1);
                double rel = test_rel_diff(got, want);
                if (!(rel <= 1.0)) /* NaN or sign flip */
                    rel = 1.0;
                worst = fmax(worst, rel);
                compared++;
            }
            print_message("fog point g=%+.1f %-26s rays %4d exempt %3d worst rel %.2e\n",
                          G_VALUES[k], cam->name, compared, exempt, worst);
            assert_true(compared > IMAGE_W * IMAGE_H / 2);
            assert_true(worst < 0.01);
            worst_all = fmax(worst_all, worst);
        }
        print_message("fog point g=%+.1f worst rel over all images %.2e\n", G_VALUES[k], worst_all);
    }
}

/* Forward scattering brightens the rays that look toward the light (the angle convention):
 * the same ray, g = +0.6 against g = -0.6. */
static void test_point_forward_brighter(void **state)
{
    (void)state;
    const double eye[3] = {0.0, 0.0, 6.0}, light[3] = {0.0, 0.0, 0.0};
    double toward[3] = {0.2, 0.1, -1.0}, away[3] = {0.2, 0.1, 1.0};
    normalize3(toward);
    normalize3(away);
    float fwd_toward = vdbs_fog_point_span(&fogs[1], eye, toward, light, 1.0, 0.0, 0.0, 1e30);
    float back_toward = vdbs_fog_point_span(&fogs[2], eye, toward, light, 1.0, 0.0, 0.0, 1e30);
    float fwd_away = vdbs_fog_point_span(&fogs[1], eye, away, light, 1.0, 0.0, 0.0, 1e30);
    float back_away = vdbs_fog_point_span(&fogs[2], eye, away, light, 1.0, 0.0, 0.0, 1e30);
    assert_true(fwd_toward > 3.0f * back_toward);
    assert_true(back_away > 3.0f * fwd_away);
}

/* ---- additivity: a lit span split anywhere sums to the whole ---- */

static void test_point_additivity(void **state)
{
    (void)state;
    const double light[3] = {0.3, -0.2, 0.1};
    const double eyes[3][3] = {{0.0, 0.0, 5.0}, {0.5, 0.5, -3.0}, {4.0, 1.0, 0.5}};
    double worst = 0.0, worst_march = 0.0;
    uint64_t rng = 12345;
    for (int k = 0; k < N_G; ++k) {
        for (int e = 0; e < 3; ++e) {
            for (int r = 0; r < 40; ++r) {
                double d[3] = {light[0] - eyes[e][0] + 3.0 * (test_uniform(&rng) - 0.5),
                               light[1] - eyes[e][1] + 3.0 * (test_uniform(&rng) - 0.5),
                               light[2] - eyes[e][2] + 3.0 * (test_uniform(&rng) - 0.5)};
                normalize3(d);
                double s0 = 0.5 * test_uniform(&rng), s1 = s0 + 1.0 + 12.0 * test_uniform(&rng);
                double whole = vdbs_fog_point_span(&fogs[k], eyes[e], d, light, 1.0, 0.0, s0, s1);
                double sum = 0.0, cuts[5];
                cuts[0] = s0;
                cuts[4] = s1;
                for (int i = 1; i < 4; ++i)
                    cuts[i] = s0 + (s1 - s0) * (0.25 * i + 0.2 * (test_uniform(&rng) - 0.5));
                for (int i = 0; i < 4; ++i) {
                    double part = vdbs_fog_point_span(&fogs[k], eyes[e], d, light, 1.0, 0.0,
                                                      cuts[i], cuts[i + 1]);
                    double want = vdbs_fog_point_march(&fogs[k].desc, eyes[e], d, light, 1.0, 0.0,
                                                       cuts[i], cuts[i + 1]);
                    /* Each part against the oracle, relative to the whole ray. */
                    worst_march = fmax(worst_march, fabs(part - want) / whole);
                    sum += part;
                }
                assert_true(whole > 0.0);
                worst = fmax(worst, fabs(sum - whole) / whole);
            }
        }
    }
    print_message("fog additivity: worst |sum of 4 parts - whole| / whole %.2e; worst part vs "
                  "march / whole %.2e\n",
                  worst, worst_march);
    assert_true(worst < 2e-6);
    assert_true(worst_march < 0.01);
}

/* ---- the sun in a fog box ---- */

/* The sun span by composite Gauss-Legendre in double: the distance to the box toward the sun
 * measured at every node. */
static double sun_quadrature(const vdbs_fog_desc *desc, const double o[3], const double d[3],
                             const double sun[3], double irradiance, const double lo[3],
                             const double hi[3], double s_enter, double s0, double s1)
{
    enum { PANELS = 2000, NODES = 4 };
    double gx[NODES], gw[NODES];
    test_gauss_legendre(NODES, 0.0, 1.0, gx, gw);
    double sum = 0.0, len = (s1 - s0) / PANELS;
    for (int p = 0; p < PANELS; ++p) {
        for (int i = 0; i < NODES; ++i) {
            double s = s0 + len * (p + gx[i]), x[3], dist = INFINITY;
            for (int a = 0; a < 3; ++a)
                x[a] = o[a] + s * d[a];
            for (int a = 0; a < 3; ++a) {
                double w = -sun[a];
                if (w > 0.0)
                    dist = fmin(dist, (hi[a] - x[a]) / w);
                else if (w < 0.0)
                    dist = fmin(dist, (lo[a] - x[a]) / w);
            }
            sum += len * gw[i] * exp(-desc->sigma_t * (s - s_enter + fmax(dist, 0.0)));
        }
    }
    double wo[3] = {-d[0], -d[1], -d[2]};
    double mu = dot3(sun, wo);
    double phase = vs_hg_eval_d(desc->g, 1.0 - mu);
    return desc->albedo * desc->sigma_t * irradiance * phase * sum;
}

static void test_sun_span(void **state)
{
    (void)state;
    const double lo[3] = {-2.0, -1.0, -2.5}, hi[3] = {3.0, 2.0, 1.5};
    const double suns[3][3] = {{0.3, -1.0, 0.2}, {-0.7, -0.2, 0.6}, {0.0, -1.0, 0.0}};
    const double eyes[2][3] = {{0.5, 0.2, -0.5}, {6.0, 4.0, 7.0}};
    uint64_t rng = 777;
    double worst = 0.0;
    int compared = 0;
    for (int k = 0; k < N_G; ++k) {
        for (int s = 0; s < 3; ++s) {
            double sun[3] = {suns[s][0], suns[s][1], suns[s][2]};
            normalize3(sun);
            for (int e = 0; e < 2; ++e) {
                for (int r = 0; r < 12; ++r) {
                    double target[3] = {lo[0] + (hi[0] - lo[0]) * test_uniform(&rng),
                                        lo[1] + (hi[1] - lo[1]) * test_uniform(&rng),
                                        lo[2] + (hi[2] - lo[2]) * test_uniform(&rng)};
                    double d[3] = {target[0] - eyes[e][0], target[1] - eyes[e][1],
                                   target[2] - eyes[e][2]};
                    normalize3(d);
                    double a, b;
                    assert_true(clip_box(eyes[e], d, lo, hi, &a, &b));
                    /* The whole chord, and a lit sub-span of it. */
                    double spans[2][2] = {{a, b}, {a + 0.2 * (b - a), a + 0.7 * (b - a)}};
                    for (int i = 0; i < 2; ++i) {
                        double want = sun_quadrature(&fogs[k].desc, eyes[e], d, sun, 2.0, lo, hi, a,
                                                     spans[i][0], spans[i][1]);
                        double got = vdbs_fog_sun_span(&fogs[k], eyes[e], d, sun, 2.0, lo, hi, a,
                                                       spans[i][0], spans[i][1]);
                        worst = fmax(worst, test_rel_diff(got, want));
                        compared++;
                    }
                }
            }
        }
    }
    print_message("fog sun: %d spans, worst rel vs quadrature %.2e\n", compared, worst);
    assert_true(worst < 1e-4);
}

/* ---- the fog's light on a Lambertian surface ---- */

/* Eq. 8 with d = infinity integrated directly: radiance arriving at P from direction u
 * (angle phi to the direction to the light) by the oracle march from P to infinity,
 * weighted by the clamped cosine max(u.n, 0), midpoint rule over (phi, theta) about the
 * light's direction (graded toward phi = 0) (the oracle's 1/sin(phi) singularity cancels with the
 * solid angle). */
static void hemisphere_oracle(const vdbs_fog_desc *desc, double l, int n_cos, const double *cos_n,
                              double reflectance, double *out)
{
    enum { NPHI = 320, NTHETA = 256 };
    const double P[3] = {0.0, 0.0, 0.0}, light[3] = {0.0, 0.0, l};
    for (int c = 0; c < n_cos; ++c)
        out[c] = 0.0;
    for (int i = 0; i < NPHI; ++i) {
        /* phi = pi v^2, midpoint rule in v: the radiance changes like phi log(phi) near the
         * light's direction, which a uniform rule in phi resolves poorly. */
        double v = (i + 0.5) / NPHI, phi = VDBS_PI * v * v, u[3] = {sin(phi), 0.0, cos(phi)};
        double lin = vdbs_fog_point_march(desc, P, u, light, 1.0, 0.0, 0.0, INFINITY);
        for (int c = 0; c < n_cos; ++c) {
            double cn = cos_n[c], sn = sqrt(fmax(0.0, 1.0 - cn * cn)), ring = 0.0;
            for (int j = 0; j < NTHETA; ++j) {
                double theta = 2.0 * VDBS_PI * (j + 0.5) / NTHETA;
                ring += fmax(0.0, cos(phi) * cn + sin(phi) * sn * cos(theta));
            }
            ring *= 2.0 * VDBS_PI / NTHETA;
            out[c] += lin * ring * sin(phi) * (2.0 * VDBS_PI * v / NPHI);
        }
    }
    for (int c = 0; c < n_cos; ++c)
        out[c] *= reflectance / VDBS_PI;
}

static void test_surface_indirect(void **state)
{
    (void)state;
    const double ls[4] = {0.7, 2.0, 6.0, 16.0}; /* lambda = 0.35 .. 8 */
    const double cos_n[7] = {1.0, 0.93, 0.37, 0.0, -0.21, -0.77, -1.0};
    double worst = 0.0;
    for (int k = 0; k < N_G; ++k) {
        for (int i = 0; i < 4; ++i) {
            double want[7];
            hemisphere_oracle(&fogs[k].desc, ls[i], 7, cos_n, 0.6, want);
            for (int c = 0; c < 7; ++c) {
                double got = vdbs_fog_surface_indirect(&fogs[k], ls[i], cos_n[c], 1.0, 0.6);
                assert_true(want[c] > 0.0); /* lit even when facing away from the light */
                if (getenv("FOG_VERBOSE"))
                    print_message("g %+.1f l %.1f cos %+.2f got %.6e want %.6e rel %.2e\n",
                                  G_VALUES[k], ls[i], cos_n[c], got, want[c],
                                  test_rel_diff(got, want[c]));
                worst = fmax(worst, test_rel_diff(got, want[c]));
            }
        }
    }
    print_message("fog surface indirect: worst rel vs hemisphere integration %.2e\n", worst);
    assert_true(worst < 0.01);
}

/* ---- Biri's Gamma (Eq. 6 with exponent lambda u(alpha)) ---- */

static void test_gamma_eq6(void **state)
{
    (void)state;
    double worst = 0.0;
    for (int k = 0; k < N_G; ++k) {
        for (int i = 0; i < 5; ++i) {
            double lambda = 0.3 + 1.9 * i * i;
            double whole = 0.0;
            for (int j = 0; j <= 8; ++j) {
                double gamma = -0.5 * VDBS_PI + VDBS_PI * (j + 0.37) / 9.0, sum = 0.0;
                enum { N = 4000 };
                for (int q = 0; q < N; ++q) { /* midpoint rule */
                    double a = gamma * (q + 0.5) / N;
                    double u = (1.0 + sin(a)) / cos(a);
                    sum += vs_hg_eval_d(G_VALUES[k], 1.0 + sin(a)) * exp(-lambda * u) * gamma / N;
                }
                if (j == 0)
                    whole = fabs(sum);
                double got = vdbs_fog_gamma(&fogs[k], lambda, gamma);
                worst = fmax(worst, fabs(got - sum) / fmax(whole, fabs(sum)));
            }
        }
    }
    print_message("fog Gamma (Eq. 6): worst error relative to |Gamma(-pi/2)| %.2e\n", worst);
    assert_true(worst < 2e-3);
}

/* ---- input checks ---- */

static void expect_rejected(vdbs_fog_desc desc)
{
    vdbs_fog fog;
    vdbs_error err;
    err.message[0] = '\0';
    assert_int_equal(vdbs_fog_build(&desc, &fog, &err), VDBS_ERR_INPUT);
    assert_null(fog.table);
    assert_true(strncmp(err.message, "fog:", 4) == 0);
}

static void test_build_rejects(void **state)
{
    (void)state;
    const vdbs_fog_desc ok = {.sigma_t = 1.0, .albedo = 0.5, .g = 0.3};
    vdbs_fog_desc d;
    d = ok, d.sigma_t = -0.1, expect_rejected(d);
    d = ok, d.sigma_t = NAN, expect_rejected(d);
    d = ok, d.sigma_t = INFINITY, expect_rejected(d);
    d = ok, d.albedo = -0.01, expect_rejected(d);
    d = ok, d.albedo = 1.01, expect_rejected(d);
    d = ok, d.albedo = NAN, expect_rejected(d);
    d = ok, d.g = 0.9995, expect_rejected(d);
    d = ok, d.g = -1.0, expect_rejected(d);
    d = ok, d.g = NAN, expect_rejected(d);
    d = ok, d.n_lambda = 3, expect_rejected(d);
    d = ok, d.n_gamma = VDBS_FOG_MAX_TABLE + 1, expect_rejected(d);
    d = ok, d.lambda_max = -2.0, expect_rejected(d);
    d = ok, d.lambert_lambda_max = NAN, expect_rejected(d);
    /* The extremes that must be accepted (small tables to stay quick), and stay finite. */
    vdbs_fog fog;
    vdbs_error err;
    d = ok, d.g = -0.999, d.albedo = 1.0, d.sigma_t = 0.0;
    d.n_lambda = d.n_gamma = d.lambert_n_lambda = d.lambert_n_cos = VDBS_FOG_MIN_TABLE;
    assert_int_equal(vdbs_fog_build(&d, &fog, &err), VDBS_OK);
    assert_int_equal(vdbs_fog_set_medium(&fog, 2.0, 0.9, &err), VDBS_OK);
    assert_int_equal(vdbs_fog_set_medium(&fog, -2.0, 0.9, &err), VDBS_ERR_INPUT);
    const double o[3] = {0.0, 0.0, 3.0}, dir[3] = {0.0, 0.6, -0.8}, light[3] = {0.0, 0.0, 0.0};
    float v = vdbs_fog_point_span(&fog, o, dir, light, 1.0, 0.0, 0.0, 1e30);
    assert_true(isfinite(v) && v > 0.0f);
    v = vdbs_fog_surface_indirect(&fog, 1.0, -0.5, 1.0, 1.0);
    assert_true(isfinite(v) && v > 0.0f);
    vdbs_fog_free(&fog);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_point_image),      cmocka_unit_test(test_point_forward_brighter),
        cmocka_unit_test(test_point_additivity), cmocka_unit_test(test_sun_span),
        cmocka_unit_test(test_surface_indirect), cmocka_unit_test(test_gamma_eq6),
        cmocka_unit_test(test_build_rejects),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
