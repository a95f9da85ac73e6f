/* The discrete phase matrix and its factorisation (vdbscatter/phasemat.h): symmetry and
 * energy (every column sums to 1) for g from -0.9 to 0.99, the full factorisation against the
 * matrix entry by entry, g = 0 as rank 1, the truncation error never rising with N and equal to
 * the reconstruction's actual Frobenius error, negative modes for negative g, delta-M where
 * the quadrature cannot resolve the peak (its first moment is then g*), the spectrum against
 * HG's closed form (eigenvalues g^l, 2l + 1 times), and bad input. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>

#include "vdbscatter/phasemat.h"

static void build(int d, double g, int delta_m, vdbs_phasemat *m)
{
    vdbs_phasemat_desc desc = {d, g, delta_m};
    vdbs_error err;
    if (vdbs_phasemat_build(&desc, m, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* Largest |column sum - 1| and largest |P_ij - P_ji|; the smallest entry. */
static void check_matrix(const vdbs_phasemat *m, double *sum_err, double *asym, double *lowest)
{
    const int d = m->d;
    *sum_err = *asym = 0.0;
    *lowest = HUGE_VAL;
    for (int j = 0; j < d; ++j) {
        double sum = 0.0;
        for (int i = 0; i < d; ++i) {
            double v = m->p[(size_t)i * d + j];
            sum += v;
            *asym = fmax(*asym, fabs(v - m->p[(size_t)j * d + i]));
            *lowest = fmin(*lowest, v);
        }
        *sum_err = fmax(*sum_err, fabs(sum - 1.0));
    }
}

static void test_matrix(void **state)
{
    (void)state;
    const double gs[] = {-0.9, -0.3, 0.0, 0.3, 0.5, 0.85, 0.99};
    for (size_t q = 0; q < sizeof gs / sizeof gs[0]; ++q) {
        vdbs_phasemat m;
        build(128, gs[q], 0, &m);
        double sum_err, asym, lowest;
        check_matrix(&m, &sum_err, &asym, &lowest);
        print_message("g %5.2f, D 128: quadrature row sums off by %.3g, delta-M f %.4f (g* %.4f); "
                      "balanced: columns sum to 1 within %.1e, symmetric within %.1e\n",
                      gs[q], m.quadrature_error, m.f, m.g_scaled, sum_err, asym);
        assert_true(sum_err < 1e-12);
        assert_true(asym < 1e-15);
        assert_true(lowest > 0.0);
        vdbs_phasemat_free(&m);
    }
}

static void test_factorisation(void **state)
{
    (void)state;
    const double gs[] = {-0.5, 0.0, 0.5, 0.9};
    for (size_t q = 0; q < sizeof gs / sizeof gs[0]; ++q) {
        vdbs_phasemat m;
        build(96, gs[q], -1, &m);
        const int d = m.d;
        /* All terms: the matrix back to rounding. */
        double worst = 0.0, norm = 0.0;
        for (int i = 0; i < d; ++i)
            for (int j = 0; j < d; ++j) {
                worst =
                    fmax(worst, fabs(vdbs_phasemat_entry(&m, d, i, j) - m.p[(size_t)i * d + j]));
                norm = fmax(norm, fabs(m.p[(size_t)i * d + j]));
            }
        assert_true(worst < 1e-12 * norm);
        assert_true(vdbs_phasemat_rmse(&m, d) == 0.0);
        /* The error never rises with N, and is the reconstruction's own at a few N. */
        for (int n = 1; n <= d; ++n)
            assert_true(vdbs_phasemat_rmse(&m, n) <= vdbs_phasemat_rmse(&m, n - 1));
        const int probe[3] = {1, 4, 16};
        for (int t = 0; t < 3; ++t) {
            double num = 0.0, den = 0.0;
            for (int i = 0; i < d; ++i)
                for (int j = 0; j < d; ++j) {
                    double p = m.p[(size_t)i * d + j],
                           e = p - vdbs_phasemat_entry(&m, probe[t], i, j);
                    num += e * e;
                    den += p * p;
                }
            assert_true(fabs(sqrt(num / den) - vdbs_phasemat_rmse(&m, probe[t])) < 1e-9);
        }
        int negative = 0;
        for (int k = 0; k < d; ++k)
            negative += m.eigval[k] < -1e-12;
        print_message("g %4.1f, D 96: rmse %.3g / %.3g / %.3g at 1 / 4 / 16 terms, %d negative "
                      "modes, full reconstruction within %.1e\n",
                      gs[q], vdbs_phasemat_rmse(&m, 1), vdbs_phasemat_rmse(&m, 4),
                      vdbs_phasemat_rmse(&m, 16), negative, worst / norm);
        if (gs[q] == 0.0)
            assert_true(vdbs_phasemat_rmse(&m, 1) < 1e-12); /* rank 1: every entry 1 / D */
        if (gs[q] < 0.0)
            assert_true(negative > 0);
        if (gs[q] > 0.0)
            assert_true(m.eigval[0] > 0.0 && fabs(m.eigval[0] - 1.0) < 1e-9); /* sums of 1 */
        vdbs_phasemat_free(&m);
    }
}

/* g 0.99 on 64 directions (spacing about 25 degrees, the peak about 1 degree wide): the
 * quadrature's sums are far off, delta-M takes f = g^8 into the beam, and the balanced
 * matrix's mean cosine sum_i P_ij (w_i . w_j) is the truncated phase's g* to 15%, where the
 * undiscretised g was 0.99 (without delta-M the peak would be lost silently). */
static void test_delta_m(void **state)
{
    (void)state;
    vdbs_phasemat m;
    build(64, 0.99, 0, &m);
    assert_true(m.quadrature_error > VDBS_PHASEMAT_DELTA_M_TOLERANCE);
    assert_true(fabs(m.f - pow(0.99, 8)) < 1e-12);
    double mean = 0.0;
    for (int j = 0; j < m.d; ++j)
        for (int i = 0; i < m.d; ++i) {
            const double *a = m.dirs + 3 * i, *b = m.dirs + 3 * j;
            mean += m.p[(size_t)i * m.d + j] * (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / m.d;
        }
    print_message("g 0.99, D 64: quadrature off by %.2f, f %.4f, g* %.4f, discrete mean cosine "
                  "%.4f\n",
                  m.quadrature_error, m.f, m.g_scaled, mean);
    assert_true(fabs(mean - m.g_scaled) < 0.15 * m.g_scaled);
    vdbs_phasemat_free(&m);
    /* A resolved peak needs none. */
    build(512, 0.3, 0, &m);
    assert_true(m.f == 0.0 && m.g_scaled == 0.3);
    vdbs_phasemat_free(&m);
}

/* The closed form: HG's Legendre moments are g^l, so the phase operator's eigenvalues are g^l,
 * each 2l + 1 times (spherical harmonics of degree l). On 256 directions with g 0.3 (a peak
 * the quadrature resolves) the sorted eigenvalues match for l = 0..3 (16 terms) to 1e-3 of
 * the first. */
static void test_spectrum(void **state)
{
    (void)state;
    vdbs_phasemat m;
    build(256, 0.3, -1, &m);
    int k = 0;
    double worst = 0.0;
    for (int l = 0; l <= 3; ++l)
        for (int r = 0; r < 2 * l + 1; ++r, ++k)
            worst = fmax(worst, fabs(m.eigval[k] - pow(0.3, l)));
    print_message("g 0.3, D 256: eigenvalues of degrees 0-3 within %.1e of g^l\n", worst);
    assert_true(worst < 1e-3);
    vdbs_phasemat_free(&m);
}

static void test_bad_input(void **state)
{
    (void)state;
    const vdbs_phasemat_desc bad[] = {{1, 0.5, 0},  {0, 0.5, 0},
                                      {64, 1.0, 0}, {64, -1.0, 0},
                                      {64, NAN, 0}, {VDBS_PHASEMAT_MAX_DIRECTIONS + 1, 0.5, 0}};
    for (size_t q = 0; q < sizeof bad / sizeof bad[0]; ++q) {
        vdbs_phasemat m;
        vdbs_error err;
        assert_int_equal(vdbs_phasemat_build(&bad[q], &m, &err), VDBS_ERR_INPUT);
        assert_null(m.p);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matrix),    cmocka_unit_test(test_factorisation),
        cmocka_unit_test(test_delta_m),   cmocka_unit_test(test_spectrum),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
