/* Flux-limited diffusion (vdbscatter/fld.h): the energy balance of the discrete system
 * (source = absorbed + leaked) on a heterogeneous medium with and without the limiter and with
 * albedo 1, and a warm start from its converged phi; the point source in a homogeneous medium
 * against the lattice Green's function (an independent Fourier evaluation written here) and against
 * the continuum's P exp(-r / L) / (4 pi D r); the limiter in empty space around a dense block; the
 * power absorbed in a high-albedo medium on cells thin against the mean free path against an
 * independent double-precision solve. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"
#include "vdbscatter/fld.h"

static const double PI = 3.14159265358979323846;

static int teardown(void **state)
{
    (void)state;
    test_runners_free();
    return 0;
}

static uint64_t rng_state = 0x2545f4914f6cdd1dull;
static int64_t cell_of(const int n[3], int i, int j, int k)
{
    return ((int64_t)k * n[1] + j) * n[0] + i;
}

/* Solves on the C path; fails the test on an error. phi starts at 0. */
static void solve(const vdbs_fld_grid *grid, const vdbs_fld_desc *desc, double *phi, double *flux,
                  vdbs_fld_stats *stats)
{
    const size_t cells = (size_t)grid->n[0] * grid->n[1] * grid->n[2];
    memset(phi, 0, sizeof *phi * 3 * cells);
    memset(stats, 0, sizeof *stats);
    vdbs_error err;
    vdbs_runner *runner = test_runner(VDBS_BACKEND_CPU);
    if (vdbs_fld_solve_grid(runner, grid, desc, phi, flux, stats, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    /* The C path's kernels read the solver's arrays: nothing is uploaded or read back. */
    vdbs_runner_transfer moved = vdbs_runner_transfers(runner);
    assert_true(moved.uploaded == 0 && moved.read_back == 0 && moved.resident_uploaded == 0);
}

/* source = absorbed + leaked to 1e-6 relative; returns the relative imbalance. */
static double check_balance(const char *label, const vdbs_fld_stats *stats)
{
    double imbalance = fabs(stats->absorbed + stats->leaked - stats->source) / stats->source;
    print_message("%s: %d solves, %d CG iterations, residual %.2e; source %.9g absorbed %.9g "
                  "leaked %.9g, imbalance %.2e\n",
                  label, stats->updates, stats->cg_iterations, stats->residual, stats->source,
                  stats->absorbed, stats->leaked, imbalance);
    assert_true(stats->source > 0.0);
    if (!(imbalance <= 1e-6))
        fail_msg("%s: absorbed + leaked %.12g, source %.12g (%.2e relative)", label,
                 stats->absorbed + stats->leaked, stats->source, imbalance);
    return imbalance;
}

static void check_phi(const char *label, const double *phi, size_t values)
{
    for (size_t v = 0; v < values; ++v)
        if (!(isfinite(phi[v]) && phi[v] >= 0.0))
            fail_msg("%s: phi[%zu] = %g", label, v, phi[v]);
}

/* ---- 1. energy balance on a heterogeneous medium ---- */

#define E_N0 20
#define E_N1 16
#define E_N2 24
#define E_CELLS (E_N0 * E_N1 * E_N2)

/* sigma_t in [0.5, 8] per unit length with a cavity of empty cells and a scatter of empty
 * ones; sources (channel-dependent) in three boxes, two of them reaching the boundary. */
static void energy_medium(float *sigma, double *source)
{
    const int n[3] = {E_N0, E_N1, E_N2};
    rng_state = 0x2545f4914f6cdd1dull;
    for (int k = 0; k < E_N2; ++k)
        for (int j = 0; j < E_N1; ++j)
            for (int i = 0; i < E_N0; ++i) {
                int64_t c = cell_of(n, i, j, k);
                double r2 =
                    (i - 12.0) * (i - 12.0) + (j - 6.0) * (j - 6.0) + (k - 14.0) * (k - 14.0);
                double s = 0.5 + 7.5 * test_uniform(&rng_state);
                if (r2 < 12.0 || test_uniform(&rng_state) < 0.15)
                    s = 0.0;
                sigma[c] = (float)s;
                int box = (i < 5 && j < 6 && k < 7) || (i >= 8 && i < 11 && j >= 9 && k >= 18) ||
                          (i >= 15 && j >= 3 && j < 7 && k >= 4 && k < 9);
                for (int ch = 0; ch < 3; ++ch)
                    source[3 * c + ch] =
                        box ? (1.0 + 0.5 * ch) * (0.2 + test_uniform(&rng_state)) : 0.0;
            }
}

static void test_energy_balance(void **state)
{
    (void)state;
    float *sigma = malloc(sizeof *sigma * E_CELLS);
    double *source = malloc(sizeof *source * 3 * E_CELLS);
    double *mono = calloc(3 * E_CELLS, sizeof *mono);
    double *phi = malloc(sizeof *phi * 3 * E_CELLS);
    assert_true(sigma && source && mono && phi);
    energy_medium(sigma, source);
    vdbs_fld_grid grid = {
        {E_N0, E_N1, E_N2}, {0.25, 0.25, 0.25}, sigma, {0.99, 0.9, 0.7}, 0.6, source, NULL, NULL};
    vdbs_fld_desc desc = {0};
    desc.tolerance = 1e-8;
    vdbs_fld_stats stats;

    solve(&grid, &desc, phi, NULL, &stats);
    check_phi("limiter on", phi, 3 * E_CELLS);
    check_balance("limiter on, albedo 0.99 / 0.9 / 0.7", &stats);
    assert_true(stats.updates >= 2 && stats.updates <= 6);

    desc.limiter_off = 1;
    solve(&grid, &desc, phi, NULL, &stats);
    check_phi("limiter off", phi, 3 * E_CELLS);
    check_balance("limiter off, albedo 0.99 / 0.9 / 0.7", &stats);
    assert_int_equal(stats.updates, 1);

    /* Albedo 1 in the red channel: nothing is absorbed there. With the source in that channel
     * only, every watt leaves through the boundary. */
    grid.albedo[0] = 1.0;
    for (int64_t c = 0; c < E_CELLS; ++c)
        mono[3 * c] = source[3 * c];
    for (int limiter_off = 0; limiter_off <= 1; ++limiter_off) {
        desc.limiter_off = limiter_off;
        grid.source = source;
        solve(&grid, &desc, phi, NULL, &stats);
        check_phi("albedo 1", phi, 3 * E_CELLS);
        check_balance(limiter_off ? "limiter off, albedo 1 / 0.9 / 0.7"
                                  : "limiter on, albedo 1 / 0.9 / 0.7",
                      &stats);
        grid.source = mono;
        solve(&grid, &desc, phi, NULL, &stats);
        check_balance(limiter_off ? "limiter off, albedo 1, red source only"
                                  : "limiter on, albedo 1, red source only",
                      &stats);
        assert_true(stats.absorbed == 0.0);
        assert_true(fabs(stats.leaked - stats.source) <= 1e-6 * stats.source);
        for (int64_t c = 0; c < E_CELLS; ++c)
            assert_true(phi[3 * c + 1] == 0.0 && phi[3 * c + 2] == 0.0);
    }

    /* The first-moment source g Q d moves first-scattered light along d but creates none:
     * the balance holds with its share through the boundary counted as leaked. */
    double *moment = calloc(9 * E_CELLS, sizeof *moment);
    assert_non_null(moment);
    const double d[3] = {0.28, 0.0, -0.96};
    for (int64_t c = 0; c < E_CELLS; ++c)
        for (int ch = 0; ch < 3; ++ch)
            for (int a = 0; a < 3; ++a)
                moment[9 * c + 3 * a + ch] = grid.g * source[3 * c + ch] * d[a];
    grid.source = source;
    grid.moment = moment;
    for (int limiter_off = 0; limiter_off <= 1; ++limiter_off) {
        desc.limiter_off = limiter_off;
        solve(&grid, &desc, phi, NULL, &stats);
        check_balance(limiter_off ? "first moment, limiter off" : "first moment, limiter on",
                      &stats);
    }
    free(moment);
    free(sigma);
    free(source);
    free(mono);
    free(phi);
}

/* A first guess (the bake's --warm-start): from the converged phi of the same system the
 * solve says it was warm, needs a fraction of the cold CG iterations and solves (the first
 * limiter comes from the guess, and its update changes phi by less than the settled 1%), and
 * ends where the cold solve did, to the limiter's own settling (the updates stop once phi
 * changes by under 1%, so two runs stop at different points of them). A zero guess is cold.
 * Measured: 2 solves and 15 CG iterations against 5 and 57, phi within 1.1e-3 of the peak. */
static void test_warm_start(void **state)
{
    (void)state;
    float *sigma = malloc(sizeof *sigma * E_CELLS);
    double *source = malloc(sizeof *source * 3 * E_CELLS);
    double *cold = malloc(sizeof *cold * 3 * E_CELLS);
    double *warm = malloc(sizeof *warm * 3 * E_CELLS);
    assert_true(sigma && source && cold && warm);
    energy_medium(sigma, source);
    vdbs_fld_grid grid = {
        {E_N0, E_N1, E_N2}, {0.25, 0.25, 0.25}, sigma, {0.99, 0.9, 0.7}, 0.6, source, NULL, NULL};
    vdbs_fld_desc desc = {0};
    desc.tolerance = 1e-6;
    vdbs_fld_stats cold_stats, warm_stats;
    solve(&grid, &desc, cold, NULL, &cold_stats);
    assert_int_equal(cold_stats.warm_start, 0);
    memcpy(warm, cold, sizeof *warm * 3 * E_CELLS);
    memset(&warm_stats, 0, sizeof warm_stats);
    vdbs_error err;
    if (vdbs_fld_solve_grid(test_runner(VDBS_BACKEND_CPU), &grid, &desc, warm, NULL, &warm_stats,
                            &err) != VDBS_OK)
        fail_msg("%s", err.message);
    check_balance("warm", &warm_stats);
    double worst = 0.0, peak = 0.0;
    for (size_t v = 0; v < 3 * E_CELLS; ++v) {
        worst = fmax(worst, fabs(warm[v] - cold[v]));
        peak = fmax(peak, cold[v]);
    }
    print_message("cold: %d solves, %d CG iterations; warm: %d solves, %d CG iterations; "
                  "largest difference %.2e of the peak\n",
                  cold_stats.updates, cold_stats.cg_iterations, warm_stats.updates,
                  warm_stats.cg_iterations, worst / peak);
    assert_int_equal(warm_stats.warm_start, 1);
    assert_true(warm_stats.updates <= 2 && warm_stats.updates < cold_stats.updates);
    assert_true(warm_stats.cg_iterations <= cold_stats.cg_iterations / 3);
    assert_true(worst <= 1e-2 * peak);
    free(sigma);
    free(source);
    free(cold);
    free(warm);
}

/* With the first moment M = g Q d of a point source in a homogeneous medium (limiter off, the
 * boundary far away), summation by parts of -div(D grad phi) + sigma_a phi = Q - div(3 D M)
 * gives the absorbed power's centroid exactly: the source's position plus 3 D M / Q =
 * g d / sigma_tr, on the lattice as in the continuum. */
static void test_first_moment_shift(void **state)
{
    (void)state;
    enum { N = 41 };
    const int n[3] = {N, N, N}, mid = N / 2;
    const int64_t cells = (int64_t)N * N * N;
    const double albedo = 0.7, g = 0.6, d[3] = {0.6, 0.0, -0.8};
    float *sigma = malloc(sizeof *sigma * (size_t)cells);
    double *source = calloc(3 * (size_t)cells, sizeof *source);
    double *moment = calloc(9 * (size_t)cells, sizeof *moment);
    double *phi = malloc(sizeof *phi * 3 * (size_t)cells);
    assert_true(sigma && source && moment && phi);
    for (int64_t c = 0; c < cells; ++c)
        sigma[c] = 1.0f;
    const int64_t centre = cell_of(n, mid, mid, mid);
    for (int ch = 0; ch < 3; ++ch) {
        source[3 * centre + ch] = 1.0;
        for (int a = 0; a < 3; ++a)
            moment[9 * centre + 3 * a + ch] = g * d[a];
    }
    vdbs_fld_grid grid = {{N, N, N}, {1.0, 1.0, 1.0}, sigma,  {albedo, albedo, albedo},
                          g,         source,          moment, NULL};
    vdbs_fld_desc desc = {0};
    desc.limiter_off = 1;
    desc.tolerance = 1e-10;
    vdbs_fld_stats stats;
    solve(&grid, &desc, phi, NULL, &stats);
    check_balance("point source with a first moment", &stats);
    const double sigma_tr = 1.0 - albedo * g;
    for (int ch = 0; ch < 3; ++ch) {
        double sum = 0.0, at[3] = {0.0, 0.0, 0.0};
        for (int k = 0; k < N; ++k)
            for (int j = 0; j < N; ++j)
                for (int i = 0; i < N; ++i) {
                    double p = phi[3 * cell_of(n, i, j, k) + ch];
                    sum += p;
                    at[0] += p * (i - mid);
                    at[1] += p * (j - mid);
                    at[2] += p * (k - mid);
                }
        double worst = 0.0;
        for (int a = 0; a < 3; ++a) {
            double expected = g * d[a] / sigma_tr;
            worst = fmax(worst, fabs(at[a] / sum - expected));
        }
        print_message("channel %d: centroid shift (%.6f, %.6f, %.6f), g d / sigma_tr (%.6f, 0, "
                      "%.6f): worst %.2e cells\n",
                      ch, at[0] / sum, at[1] / sum, at[2] / sum, g * d[0] / sigma_tr,
                      g * d[2] / sigma_tr, worst);
        /* Measured 6.9e-6 cells: the 1.6e-6 of the power that leaks 20 cells away. */
        assert_true(worst <= 2e-5);
    }
    free(sigma);
    free(source);
    free(moment);
    free(phi);
}

/* ---- 2. a point source in a homogeneous medium ---- */

/* The lattice Green's function of the 7-point operator with h = 1:
 *   sum over the 6 neighbours of D (G(m) - G(m')) + sigma_a G(m) = delta(m),
 * (D / h^2 in place of D for other cells), G(m) = (2 pi)^-3 int_[-pi,pi]^3 cos(k . m) / (sigma_a +
 * 2 D sum (1 - cos k_a)) dk. The k_z integral in closed form, (2 pi)^-1 int cos(k m) / (a - b cos
 * k) dk = rho^|m| / sqrt(a^2 - b^2) with rho = (a - sqrt(a^2 - b^2)) / b; the remaining periodic,
 * analytic integrand by the trapezoidal rule (exponentially convergent: 256 points per axis reach
 * 1e-12 here). */
static double lattice_green(double d, double sigma_a, const int m[3])
{
    const int points = 256;
    const double b = 2.0 * d;
    double sum = 0.0;
    for (int p = 0; p < points; ++p) {
        double kx = -PI + 2.0 * PI * p / points;
        for (int q = 0; q < points; ++q) {
            double ky = -PI + 2.0 * PI * q / points;
            double a = sigma_a + 2.0 * d * (3.0 - cos(kx) - cos(ky));
            double root = sqrt(a * a - b * b);
            sum += cos(kx * m[0]) * cos(ky * m[1]) * pow((a - root) / b, abs(m[2])) / root;
        }
    }
    return sum / ((double)points * points);
}

#define G_N 61
#define G_CELLS (G_N * G_N * G_N)

/* A unit point source (Q = 1 / h^3 in the centre cell, every channel) in a homogeneous medium
 * of sigma_t 1, g 0, on 61^3 cells of side h with the limiter off; phi at 3..10 cells from the
 * source along an axis, a face diagonal and the body diagonal against the lattice Green's
 * function (to lattice_bound relative: the solver against the exact solution of its own
 * equations) and against the continuum P exp(-r / L) / (4 pi D r) (to continuum_bound). */
static void point_source(double h, double albedo, double lattice_bound, double continuum_bound)
{
    const int n[3] = {G_N, G_N, G_N}, mid = G_N / 2;
    const double sigma_t = 1.0;
    const double d = 1.0 / (3.0 * sigma_t), sigma_a = sigma_t * (1.0 - albedo);
    const double len = sqrt(d / sigma_a), power = 1.0;
    float *sigma = malloc(sizeof *sigma * G_CELLS);
    double *source = calloc(3 * G_CELLS, sizeof *source);
    double *phi = malloc(sizeof *phi * 3 * G_CELLS);
    assert_true(sigma && source && phi);
    for (int64_t c = 0; c < G_CELLS; ++c)
        sigma[c] = (float)sigma_t;
    const int64_t centre = cell_of(n, mid, mid, mid);
    for (int ch = 0; ch < 3; ++ch)
        source[3 * centre + ch] = power / (h * h * h);
    vdbs_fld_grid grid = {{G_N, G_N, G_N}, {h, h, h}, sigma, {albedo, albedo, albedo}, 0.0,
                          source,          NULL,      NULL};
    vdbs_fld_desc desc = {0};
    desc.limiter_off = 1;
    desc.tolerance = 1e-9;
    vdbs_fld_stats stats;
    solve(&grid, &desc, phi, NULL, &stats);
    print_message("point source, %d^3 cells of %.2f, D %.4f, sigma_a %.3f, L %.3f cells: %d CG "
                  "iterations, residual %.2e\n",
                  G_N, h, d, sigma_a, len / h, stats.cg_iterations, stats.residual);
    assert_true(stats.residual <= 1e-9);
    check_phi("point source", phi, 3 * G_CELLS);
    /* Not asserted here: the float diagonal (sigma_a + 6 D / h^2 rounded) carries an effective
     * sigma_a off by 1.5e-6 relative, and the double tally then finds an imbalance of that
     * size (test_absorption_fine_cells). */
    print_message("point source: source %.9g absorbed %.9g leaked %.9g, imbalance %.2e\n",
                  stats.source, stats.absorbed, stats.leaked,
                  (stats.absorbed + stats.leaked - stats.source) / stats.source);

    /* Along an axis (r = 3..10 cells), a face diagonal (4.2..9.9) and the body diagonal
     * (3.5..8.7). */
    static const int probes[][3] = {{3, 0, 0}, {4, 0, 0}, {5, 0, 0},  {6, 0, 0}, {7, 0, 0},
                                    {8, 0, 0}, {9, 0, 0}, {10, 0, 0}, {3, 3, 0}, {4, 4, 0},
                                    {5, 5, 0}, {6, 6, 0}, {7, 7, 0},  {2, 2, 2}, {3, 3, 3},
                                    {4, 4, 4}, {5, 5, 5}};
    double worst_lattice = 0.0, worst_continuum = 0.0;
    for (size_t p = 0; p < sizeof probes / sizeof probes[0]; ++p) {
        const int *m = probes[p];
        double r = h * sqrt((double)(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]));
        double continuum = power * exp(-r / len) / (4.0 * PI * d * r);
        double lattice = lattice_green(d / (h * h), sigma_a, m) * power / (h * h * h);
        int64_t c = cell_of(n, mid + m[0], mid + m[1], mid + m[2]);
        double worst_channel = 0.0;
        for (int ch = 0; ch < 3; ++ch)
            worst_channel = fmax(worst_channel, fabs(phi[3 * c + ch] - lattice) / lattice);
        worst_lattice = fmax(worst_lattice, worst_channel);
        double to_continuum = phi[3 * c] / continuum - 1.0;
        worst_continuum = fmax(worst_continuum, fabs(to_continuum));
        print_message("(%d,%d,%d) r %.2f cells: phi %.6e, lattice %.6e (%.1e), continuum %.6e "
                      "(%+.2f%%)\n",
                      m[0], m[1], m[2], r / h, phi[3 * c], lattice, worst_channel, continuum,
                      100.0 * to_continuum);
        if (!(worst_channel <= lattice_bound))
            fail_msg("(%d,%d,%d): phi %.9g, lattice Green's function %.9g", m[0], m[1], m[2],
                     phi[3 * c], lattice);
        if (!(fabs(to_continuum) <= continuum_bound))
            fail_msg("(%d,%d,%d) r %.2f cells: phi %.9g, continuum %.9g (%+.2f%%)", m[0], m[1],
                     m[2], r / h, phi[3 * c], continuum, 100.0 * to_continuum);
    }
    print_message("point source, L %.2f cells: worst %.2e from the lattice Green's function, "
                  "%.2f%% from the continuum\n",
                  len / h, worst_lattice, 100.0 * worst_continuum);
    free(sigma);
    free(source);
    free(phi);
}

static void test_point_source(void **state)
{
    (void)state;
    /* Against its own discrete equations the solver is exact to 2.4e-8 (h 1) and 1.4e-6
     * (h 0.5; with sigma_a folded into a float diagonal it was 4.2e-6 and 3.3e-6, growing with
     * r). Against the continuum the 7-point lattice is anisotropic at these L / h:
     * measured with h 1 (L 1.83 cells) +13.5% on the axis at r 3, +7.9..+8.8% at r 6..10,
     * -0.6..-2.4% on the face diagonal, -4.1..-7.8% on the body diagonal; with h 0.5 (L 3.65
     * cells) +7.6% on the axis at r 3, +4.7% at r 4, +1.9..+3.4% at r 5..10, -0.7..-1.1% and
     * -1.7..-3.8% on the diagonals. (h 1/3, L 5.48 cells: +6.2% at r 3, +2.4% at r 5; there
     * the finite grid's leak, 1.6% of the power, departs from the infinite lattice by 1e-5;
     * h 1/4, L 7.3 cells: still +5.5% at r 3, so it is the lattice near the source, whatever
     * L.)
     * The 3% asked of the continuum holds only from r 5 with h 0.5: the bounds below are the
     * measured errors, rounded up, and the lattice Green's function is the tight oracle. */
    point_source(1.0, 0.9, 1e-5, 0.14);
    point_source(0.5, 0.9, 1e-5, 0.08);
}

/* ---- 4. the limiter in empty space ---- */

#define B_N 24
#define B_CELLS (B_N * B_N * B_N)

static void test_limiter_empty_space(void **state)
{
    (void)state;
    const int n[3] = {B_N, B_N, B_N};
    float *sigma = calloc(B_CELLS, sizeof *sigma);
    double *source = calloc(3 * B_CELLS, sizeof *source);
    double *phi = malloc(sizeof *phi * 3 * B_CELLS);
    double *flux = malloc(sizeof *flux * 9 * B_CELLS);
    assert_true(sigma && source && phi && flux);
    /* A dense block of 8^3 cells (optical depth 40 across) off the centre, the rest empty;
     * the source in its core. */
    for (int k = 7; k < 15; ++k)
        for (int j = 9; j < 17; ++j)
            for (int i = 8; i < 16; ++i) {
                int64_t c = cell_of(n, i, j, k);
                sigma[c] = 10.0f;
                int core = i >= 10 && i < 14 && j >= 11 && j < 15 && k >= 9 && k < 13;
                for (int ch = 0; ch < 3; ++ch)
                    source[3 * c + ch] = core ? 2.0 + ch : 0.0;
            }
    vdbs_fld_grid grid = {
        {B_N, B_N, B_N}, {0.5, 0.5, 0.5}, sigma, {0.99, 0.9, 0.7}, 0.6, source, NULL, NULL};
    vdbs_fld_desc desc = {0};
    desc.tolerance = 1e-8;
    vdbs_fld_stats stats;
    solve(&grid, &desc, phi, flux, &stats);
    check_phi("dense block in empty space", phi, 3 * B_CELLS);
    for (size_t v = 0; v < 9 * (size_t)B_CELLS; ++v)
        if (!isfinite(flux[v]))
            fail_msg("flux[%zu] = %g", v, flux[v]);
    double lo = HUGE_VAL, hi = 0.0;
    for (int64_t c = 0; c < B_CELLS; ++c)
        if (sigma[c] == 0.0f) {
            lo = fmin(lo, phi[3 * c]);
            hi = fmax(hi, phi[3 * c]);
        }
    print_message("dense block in empty space: phi in the empty cells %.4e..%.4e (red)\n", lo, hi);
    assert_true(lo > 0.0);
    check_balance("dense block in empty space, limiter on", &stats);
    free(sigma);
    free(source);
    free(phi);
    free(flux);
}

/* ---- 4b. light arriving through the boundary (the sky's uniform part, skyfloor.h) ----
 * A uniform radiance L around the grid enters every boundary face as the current pi L. With
 * nothing absorbed, phi = 4 pi L in every cell solves the discrete equations exactly (the
 * white furnace), whatever the medium: the heterogeneous medium of test 1, a dense block in
 * empty space, g 0.6. With absorption, what the boundary let in counts in the source, and
 * source = absorbed + leaked. */
static void test_boundary_inflow(void **state)
{
    (void)state;
    const int n[3] = {B_N, B_N, B_N};
    float *sigma = calloc(B_CELLS, sizeof *sigma);
    double *source = calloc(3 * B_CELLS, sizeof *source);
    double *phi = malloc(sizeof *phi * 3 * B_CELLS);
    assert_true(sigma && source && phi);
    for (int k = 7; k < 15; ++k)
        for (int j = 9; j < 17; ++j)
            for (int i = 8; i < 16; ++i)
                sigma[cell_of(n, i, j, k)] = 10.0f + (float)((i * 7 + j * 3 + k) % 5);
    const double radiance[3] = {1.0, 2.0, 0.5};
    double inflow[18];
    for (int i = 0; i < 18; ++i)
        inflow[i] = PI * radiance[i % 3];
    vdbs_fld_grid grid = {
        {B_N, B_N, B_N}, {0.5, 0.5, 0.5}, sigma, {1.0, 1.0, 1.0}, 0.6, source, NULL, inflow};
    vdbs_fld_desc desc = {0};
    desc.tolerance = 1e-8;
    vdbs_fld_stats stats;
    solve(&grid, &desc, phi, NULL, &stats);
    double worst = 0.0;
    for (int64_t c = 0; c < B_CELLS; ++c)
        for (int ch = 0; ch < 3; ++ch)
            worst = fmax(worst, fabs(phi[3 * c + ch] / (4.0 * PI * radiance[ch]) - 1.0));
    print_message("boundary inflow, albedo 1: phi / (4 pi L) within %.2e of 1\n", worst);
    assert_true(worst <= 1e-6);
    check_balance("boundary inflow, albedo 1", &stats);
    grid.albedo[0] = 0.9, grid.albedo[1] = 0.5, grid.albedo[2] = 0.0;
    solve(&grid, &desc, phi, NULL, &stats);
    check_phi("boundary inflow, absorbing", phi, 3 * B_CELLS);
    assert_true(stats.absorbed > 0.0);
    check_balance("boundary inflow, absorbing", &stats);
    free(sigma);
    free(source);
    free(phi);
}

/* ---- 5. the absorption where sigma_a is small against D / h^2 ---- */

/* An independent solve of the discrete equations, limiter off, all in double: D = 1 /
 * (3 sigma_tr) per cell (sigma_t > 0 everywhere), harmonic-mean couplings over h^2, the
 * Marshak leak 2 D / ((h + 4 D) h) per boundary face, sigma_a on the diagonal;
 * Jacobi-preconditioned CG to a relative residual of 1e-13. */
static void reference_solve(const vdbs_fld_grid *grid, int ch, double *phi)
{
    const int *n = grid->n;
    const int64_t cells = (int64_t)n[0] * n[1] * n[2];
    const int64_t stride[3] = {1, n[0], (int64_t)n[0] * n[1]};
    const double h = grid->h[0]; /* cubic */
    double *diag = malloc(sizeof *diag * cells), *up = malloc(sizeof *up * 3 * cells);
    double *r = malloc(sizeof *r * cells), *z = malloc(sizeof *z * cells);
    double *p = malloc(sizeof *p * cells), *ap = malloc(sizeof *ap * cells);
    assert_true(diag && up && r && z && p && ap);
    for (int64_t c = 0; c < cells; ++c) {
        const int at[3] = {(int)(c % n[0]), (int)(c / n[0] % n[1]), (int)(c / stride[2])};
        double sigma_t = grid->sigma_t[c],
               d = 1.0 / (3.0 * sigma_t * (1.0 - grid->albedo[ch] * grid->g));
        diag[c] = sigma_t * (1.0 - grid->albedo[ch]);
        for (int a = 0; a < 3; ++a) {
            up[3 * c + a] = 0.0;
            for (int side = -1; side <= 1; side += 2) {
                int inside = side > 0 ? at[a] + 1 < n[a] : at[a] > 0;
                if (!inside) {
                    diag[c] += 2.0 * d / ((h + 4.0 * d) * h);
                    continue;
                }
                int64_t o = c + side * stride[a];
                double dn = 1.0 / (3.0 * grid->sigma_t[o] * (1.0 - grid->albedo[ch] * grid->g));
                double coupling = 2.0 * d * dn / (d + dn) / (h * h);
                diag[c] += coupling;
                if (side > 0)
                    up[3 * c + a] = coupling;
            }
        }
    }
    double b_norm = 0.0, rz = 0.0;
    for (int64_t c = 0; c < cells; ++c) {
        phi[c] = 0.0;
        r[c] = grid->source[3 * c + ch];
        z[c] = r[c] / diag[c];
        p[c] = z[c];
        rz += r[c] * z[c];
        b_norm += r[c] * r[c];
    }
    b_norm = sqrt(b_norm);
    for (int it = 0; it < 20000; ++it) {
        double pap = 0.0;
        for (int64_t c = 0; c < cells; ++c) {
            const int at[3] = {(int)(c % n[0]), (int)(c / n[0] % n[1]), (int)(c / stride[2])};
            double y = diag[c] * p[c];
            for (int a = 0; a < 3; ++a) {
                if (at[a] + 1 < n[a])
                    y -= up[3 * c + a] * p[c + stride[a]];
                if (at[a] > 0)
                    y -= up[3 * (c - stride[a]) + a] * p[c - stride[a]];
            }
            ap[c] = y;
            pap += p[c] * y;
        }
        double alpha = rz / pap, rz_new = 0.0, r_norm = 0.0;
        for (int64_t c = 0; c < cells; ++c) {
            phi[c] += alpha * p[c];
            r[c] -= alpha * ap[c];
            z[c] = r[c] / diag[c];
            rz_new += r[c] * z[c];
            r_norm += r[c] * r[c];
        }
        if (sqrt(r_norm) <= 1e-13 * b_norm)
            break;
        for (int64_t c = 0; c < cells; ++c)
            p[c] = z[c] + rz_new / rz * p[c];
        rz = rz_new;
    }
    free(diag);
    free(up);
    free(r);
    free(z);
    free(p);
    free(ap);
}

/* Absorption must not drown in the couplings: where sigma_a is a small part of the diagonal
 * (high albedo, cells thin against the mean free path) a float diagonal sigma_a + sum
 * D / h^2 + leak would round away a visible part of it (measured with that layout: the
 * effective sigma_a 5.5e-4 / 3.6e-4 / 2.5e-5 off, the absorbed power 2.2e-6 / 1.7e-5 / 9.2e-6).
 * The operator keeps sigma_a, the leak and the couplings as their own words. A cloud-like
 * homogeneous medium (sigma_t 2, h 0.25, g 0.85, albedo 0.999 / 0.99 / 0.9), limiter off: the
 * power absorbed, sum sigma_a phi V per channel, against an independent double-precision solve
 * to 1e-6 (measured 3e-9 / 2.5e-8 / 1.6e-8), and the balance. (sigma_t 2, not 1: fld.c caps D
 * at the grid's extent / 3 even with the limiter off; with sigma_t 1 on these 5 units the cap
 * binds in the two high-albedo channels, which then absorb 9.6% and 7.8% more than classic
 * diffusion.) */
#define F_N 20
#define F_CELLS (F_N * F_N * F_N)

static void test_absorption_fine_cells(void **state)
{
    (void)state;
    const int n[3] = {F_N, F_N, F_N};
    const double h = 0.25, g = 0.85, albedo[3] = {0.999, 0.99, 0.9}, sigma_t = 2.0;
    float *sigma = malloc(sizeof *sigma * F_CELLS);
    double *source = calloc(3 * F_CELLS, sizeof *source);
    double *phi = malloc(sizeof *phi * 3 * F_CELLS), *ref = malloc(sizeof *ref * F_CELLS);
    assert_true(sigma && source && phi && ref);
    for (int64_t c = 0; c < F_CELLS; ++c)
        sigma[c] = (float)sigma_t;
    for (int k = 8; k < 12; ++k)
        for (int j = 8; j < 12; ++j)
            for (int i = 8; i < 12; ++i)
                for (int ch = 0; ch < 3; ++ch)
                    source[3 * cell_of(n, i, j, k) + ch] = 1.0;
    vdbs_fld_grid grid = {{F_N, F_N, F_N}, {h, h, h}, sigma, {albedo[0], albedo[1], albedo[2]}, g,
                          source,          NULL,      NULL};
    vdbs_fld_desc desc = {0};
    desc.limiter_off = 1;
    desc.tolerance = 1e-9;
    vdbs_fld_stats stats;
    solve(&grid, &desc, phi, NULL, &stats);
    check_phi("fine cells", phi, 3 * F_CELLS);
    check_balance("fine cells, albedo 0.999 / 0.99 / 0.9, g 0.85, limiter off", &stats);
    double worst = 0.0;
    for (int ch = 0; ch < 3; ++ch) {
        const double sigma_a = sigma_t * (1.0 - albedo[ch]);
        reference_solve(&grid, ch, ref);
        double got = 0.0, want = 0.0, peak = 0.0, diff = 0.0;
        for (int64_t c = 0; c < F_CELLS; ++c) {
            got += sigma_a * phi[3 * c + ch] * h * h * h;
            want += sigma_a * ref[c] * h * h * h;
            peak = fmax(peak, ref[c]);
            diff = fmax(diff, fabs(phi[3 * c + ch] - ref[c]));
        }
        double off = got / want - 1.0;
        worst = fmax(worst, fabs(off));
        print_message("albedo %.3f: absorbed %.9g, reference %.9g (%+.2e); phi within %.2e of "
                      "the peak\n",
                      albedo[ch], got, want, off, diff / peak);
    }
    if (!(worst <= 1e-6))
        fail_msg("absorbed power %.2e off the double reference", worst);
    free(sigma);
    free(source);
    free(phi);
    free(ref);
}

/* ---- 6. the solver's work as the grid is refined ---- */

/* CG iterations of one solve of the same physical problem on n^3 cells: a unit cube of
 * sigma_t 8 (albedo 0.99, limiter off; 8 transport paths across) lit by a source in the
 * cube [0.25, 0.5]^3, at relative residual 1e-8. */
static int iterations_at(int n, int runner_cells)
{
    const int64_t cells = (int64_t)n * n * n;
    const int dims[3] = {n, n, n};
    float *sigma = malloc(sizeof *sigma * (size_t)cells);
    double *source = calloc(3 * (size_t)cells, sizeof *source);
    double *phi = malloc(sizeof *phi * 3 * (size_t)cells);
    assert_true(sigma && source && phi);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const int64_t c = cell_of(dims, i, j, k);
                sigma[c] = 8.0f;
                const int inside =
                    4 * i >= n && 2 * i < n && 4 * j >= n && 2 * j < n && 4 * k >= n && 2 * k < n;
                for (int ch = 0; ch < 3; ++ch)
                    source[3 * c + ch] = inside ? 1.0 : 0.0;
            }
    vdbs_fld_grid grid = {
        {n, n, n}, {1.0 / n, 1.0 / n, 1.0 / n}, sigma, {0.99, 0.99, 0.99}, 0.0, source, NULL, NULL};
    vdbs_fld_desc desc = {0};
    desc.limiter_off = 1;
    desc.tolerance = 1e-8;
    desc.runner_cells = runner_cells;
    vdbs_fld_stats stats;
    solve(&grid, &desc, phi, NULL, &stats);
    check_balance("refinement", &stats);
    print_message("%d^3 cells: %d levels, %d CG iterations (3 channels), %d operator "
                  "applications\n",
                  n, stats.levels, stats.cg_iterations, stats.operator_applications);
    free(sigma);
    free(source);
    free(phi);
    return stats.cg_iterations;
}

/* The multigrid V-cycle keeps CG's iterations nearly flat as the cells shrink (the
 * condition number grows as n^2, so Jacobi-preconditioned CG needs about 4x the iterations
 * for 4x the cells across). Measured 39 / 45 / 54 iterations at 16 / 32 / 64 cells (the
 * solve is deterministic); the bar is 1.5x from 16 to 64. Host loop or runner for the small
 * levels gives the same iterations. */
static void test_iterations_flat_under_refinement(void **state)
{
    (void)state;
    const int coarse = iterations_at(16, 0);
    iterations_at(32, 0);
    const int fine = iterations_at(64, 0);
    assert_true(fine <= 1.5 * coarse);
    assert_int_equal(iterations_at(16, 1), coarse);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_energy_balance),
        cmocka_unit_test(test_warm_start),
        cmocka_unit_test(test_first_moment_shift),
        cmocka_unit_test(test_point_source),
        cmocka_unit_test(test_limiter_empty_space),
        cmocka_unit_test(test_boundary_inflow),
        cmocka_unit_test(test_absorption_fine_cells),
        cmocka_unit_test(test_iterations_flat_under_refinement),
    };
    return cmocka_run_group_tests(tests, NULL, teardown);
}
