/* The discrete-ordinates sweep (--method svd) against this machine's memory bandwidth, side by
 * side in one run, on the C path:
 *
 * - the bound: a triad a = b + s c over arrays far larger than any cache, with OpenMP's
 *   threads, the best of several passes (bytes read and written per second);
 * - the sweep: vdbs_svd_solve_grid on an n^3 grid of a uniform medium lit by a sun and a sky
 *   projected on the terms, a fixed number of sweeps, at each quality's D, N and n; its
 *   cell-direction-term updates per second, and the bytes a sweep must move at the least: every
 *   octant reads each cell's 3 N source moments and reads and writes its 3 N new moments
 *   (the direction table and the planes in flight stay in cache), over the time a sweep took.
 *   Their ratio to the triad's rate is the sweep's fraction of the bandwidth bound.
 *
 * Prints a Markdown table. usage: bench_svd_sweep [SWEEPS] */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/phasemat.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/svd.h"

/* Floats per triad array: 3 x 256 MiB, far past the last-level cache. */
#define TRIAD_FLOATS ((size_t)64 << 20)
#define TRIAD_PASSES 5

/* Bytes per second of the best triad pass (two arrays read, one written). */
static double triad_rate(void)
{
    float *a = malloc(sizeof *a * TRIAD_FLOATS), *b = malloc(sizeof *b * TRIAD_FLOATS),
          *c = malloc(sizeof *c * TRIAD_FLOATS);
    if (!a || !b || !c) {
        free(a);
        free(b);
        free(c);
        return 0.0;
    }
    const int64_t n = (int64_t)TRIAD_FLOATS;
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
        a[i] = 0.0f;
        b[i] = 1.0f;
        c[i] = 2.0f;
    }
    double best = 1e30;
    for (int pass = 0; pass < TRIAD_PASSES; ++pass) {
        const float s = 0.5f + (float)pass;
        double t0 = omp_get_wtime();
#pragma omp parallel for schedule(static)
        for (int64_t i = 0; i < n; ++i)
            a[i] = b[i] + s * c[i];
        best = fmin(best, omp_get_wtime() - t0);
    }
    double check = a[n / 2]; /* keeps the stores */
    free(a);
    free(b);
    free(c);
    return check > 0.0 ? 3.0 * sizeof(float) * (double)n / best : 0.0;
}

typedef struct sweep_case {
    const char *label;
    int n, directions, terms;
} sweep_case;

typedef struct sweep_result {
    double seconds_per_sweep, updates_per_second, bytes_per_second;
    int directions, terms;
} sweep_result;

static int sweep_run(vdbs_runner *runner, const sweep_case *sc, int sweeps, sweep_result *out)
{
    vdbs_phasemat pm;
    vdbs_phasemat_desc pd = {sc->directions, 0.85, 1};
    vdbs_error err;
    if (vdbs_phasemat_build(&pd, &pm, &err) != VDBS_OK) {
        fprintf(stderr, "bench_svd_sweep: %s\n", err.message);
        return 1;
    }
    const int terms = sc->terms < pm.d ? sc->terms : pm.d;
    const size_t cells = (size_t)sc->n * sc->n * sc->n;
    float *sigma = malloc(sizeof *sigma * cells);
    float *direct = malloc(sizeof *direct * cells * 3);
    float *sky = malloc(sizeof *sky * cells * (size_t)terms * 3);
    if (!sigma || !direct || !sky) {
        free(sigma);
        free(direct);
        free(sky);
        vdbs_phasemat_free(&pm);
        return 1;
    }
    /* Optical depth 20 across, a sun's first scattering fading with depth, a sky source on
     * every term: every cell and term carries light, as inside a cloud. */
    const double h = 1.0 / sc->n, sigma_t = 20.0;
    for (size_t c = 0; c < cells; ++c) {
        sigma[c] = (float)sigma_t;
        const double depth = (double)(c / ((size_t)sc->n * sc->n)) * h * sigma_t;
        for (int ch = 0; ch < 3; ++ch)
            direct[3 * c + ch] = (float)(sigma_t * exp(-depth));
        for (int k = 0; k < terms * 3; ++k)
            sky[c * (size_t)terms * 3 + (size_t)k] = (float)(0.05 * sigma_t / (1 + k));
    }
    const vdbs_svd_light sun = {0, {0.2822, -0.9407, 0.1881}}; /* unit */
    const vdbs_svd_grid grid = {.n = {sc->n, sc->n, sc->n},
                                .h = {h, h, h},
                                .sigma_t = sigma,
                                .albedo = {0.99, 0.99, 0.99},
                                .phase = &pm,
                                .terms = terms,
                                .lights = &sun,
                                .light_count = 1,
                                .direct = direct,
                                .sky = sky};
    vdbs_svd_desc desc = {0};
    desc.max_iterations = sweeps;
    desc.residual = 1e-30; /* every sweep runs */
    vdbs_svd_stats stats;
    double t0 = omp_get_wtime();
    vdbs_status st = vdbs_svd_solve_grid(runner, &grid, &desc, NULL, NULL, NULL, &stats, &err);
    double seconds = omp_get_wtime() - t0;
    if (st != VDBS_OK)
        fprintf(stderr, "bench_svd_sweep: %s\n", err.message);
    else {
        out->directions = pm.d;
        out->terms = terms;
        out->seconds_per_sweep = seconds / stats.iterations;
        out->updates_per_second = (double)cells * pm.d * terms / out->seconds_per_sweep;
        /* Per octant: the source read, the moments read and written, 3 N floats each. */
        out->bytes_per_second =
            8.0 * (double)cells * 3.0 * terms * 3.0 * sizeof(float) / out->seconds_per_sweep;
    }
    free(sigma);
    free(direct);
    free(sky);
    vdbs_phasemat_free(&pm);
    return st == VDBS_OK ? 0 : 1;
}

int main(int argc, char **argv)
{
    const int sweeps = argc > 1 ? atoi(argv[1]) : 4;
    if (sweeps < 1) {
        fprintf(stderr, "usage: bench_svd_sweep [SWEEPS]\n");
        return 2;
    }
    vdbs_runner_desc rd = {0};
    rd.backend = VDBS_BACKEND_CPU;
    vdbs_runner *runner;
    vdbs_error err;
    if (vdbs_runner_create(&rd, &runner, &err) != VDBS_OK) {
        fprintf(stderr, "bench_svd_sweep: %s\n", err.message);
        return 1;
    }
    const double bound = triad_rate();
    /* The qualities' D and grids (vdbs_svd_quality), N = D as their tolerances choose on the
     * sample cloud (g 0.85 after delta-M), and a factored case. */
    const sweep_case cases[] = {
        {"low", 16, 32, 32},    {"medium", 24, 64, 64},      {"medium, N 16", 24, 64, 16},
        {"high", 32, 128, 128}, {"high, N 32", 32, 128, 32},
    };
    printf("Triad bound: %.2f GB/s (%d threads; the best of %d passes over 3 x %zu MiB).\n\n",
           bound / 1e9, omp_get_max_threads(), TRIAD_PASSES, TRIAD_FLOATS * sizeof(float) >> 20);
    printf("| case | cells | D | N | s / sweep | G cell-direction-terms / s | least GB / s moved | "
           "fraction of the bound |\n|---|---|---|---|---|---|---|---|\n");
    int failed = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        sweep_result r;
        if (sweep_run(runner, &cases[i], sweeps, &r) != 0) {
            failed = 1;
            continue;
        }
        printf("| %s | %d^3 | %d | %d | %.4f | %.3f | %.2f | %.2f |\n", cases[i].label, cases[i].n,
               r.directions, r.terms, r.seconds_per_sweep, r.updates_per_second / 1e9,
               r.bytes_per_second / 1e9, bound > 0.0 ? r.bytes_per_second / bound : 0.0);
    }
    vdbs_runner_destroy(runner);
    return failed;
}
