/* The kernel runner on both backends, with a kernel shaped like the propagation solvers: a
 * 6-neighbour Jacobi step over ping-pong grids with a max-change reduction after each step
 * (shaders/vs_stencil.h, shaders/test_jacobi.comp).
 *
 * Oracle: for -Laplace(u) = f with f = 6 (1 - rho) u*, u* the lowest discrete sine mode of
 * an nx x ny x nz grid and rho = (cos(pi/(nx+1)) + cos(pi/(ny+1)) + cos(pi/(nz+1))) / 3,
 * Jacobi from u = 0 gives exactly u_k = (1 - rho^k) u*, and step k changes u by
 * rho^(k-1) (1 - rho) u*.
 *
 * And a sweep in dependency order (in place, plane after plane, with a sum reduction),
 * whose planes are exact binary fractions (shaders/test_sweep.comp). And the bytes the runner
 * counts as moved, exactly, from the buffer sizes of each call. The C path runs on 1, 2 and 4
 * threads whatever OMP_NUM_THREADS says (the steps' own barrier: 4 threads wait for cores). */
#include "testutil.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_pass.h"
#include "vs_stencil.h"

/* Items not a multiple of the work-group size, so that partial groups are exercised. */
#define PI 3.14159265358979323846

#define NX 12
#define NY 11
#define NZ 13
#define ITEMS (NX * NY * NZ)

typedef struct problem {
    float rhs[ITEMS];
    double exact[ITEMS]; /* u* */
    int dims[3];
    double rho, peak; /* peak = max u* */
} problem;

static problem P;

#define PLANE (NX * NY)

static int setup(void **state)
{
    (void)state;
    const int n[3] = {NX, NY, NZ};
    double c[3];
    for (int a = 0; a < 3; ++a) {
        P.dims[a] = n[a];
        c[a] = cos(PI / (n[a] + 1));
    }
    P.rho = (c[0] + c[1] + c[2]) / 3.0;
    P.peak = 0.0;
    for (int k = 0; k < NZ; ++k)
        for (int j = 0; j < NY; ++j)
            for (int i = 0; i < NX; ++i) {
                int m = i + NX * (j + NY * k);
                P.exact[m] = sin(PI * (i + 1) / (NX + 1)) * sin(PI * (j + 1) / (NY + 1)) *
                             sin(PI * (k + 1) / (NZ + 1));
                P.rhs[m] = (float)(6.0 * (1.0 - P.rho) * P.exact[m]);
                P.peak = fmax(P.peak, P.exact[m]);
            }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    test_runners_free();
    return 0;
}

static double jacobi_step(void *user, int step, const void *state_in, void *state_out,
                          uint64_t begin, uint64_t end)
{
    (void)step;
    const problem *p = user;
    const float *in = state_in;
    float *out = state_out;
    double change = 0.0;
    for (uint64_t n = begin; n < end; ++n) {
        out[n] = vs_jacobi_item(in, p->rhs, (int)n, p->dims[0], p->dims[1], p->dims[2]);
        change = fmax(change, fabs((double)out[n] - in[n]));
    }
    return change;
}

/* The Jacobi kernel's description: up to `iterations` steps from u (the caller zeroes it). */
static vdbs_kernel_desc jacobi_desc(int iterations, double tolerance, uint64_t gpu_chunk, float *u)
{
    vdbs_kernel_desc desc = {0};
    desc.items = ITEMS;
    desc.user = &P;
    desc.cpu_step = jacobi_step;
    desc.cpu_chunk = 100;
    desc.shader = "test_jacobi.comp";
    desc.inputs[1] = (vdbs_kernel_input){.data = P.rhs, .size = sizeof P.rhs};
    desc.inputs[2] = (vdbs_kernel_input){.data = P.dims, .size = sizeof P.dims};
    desc.state_words = 1;
    desc.state = u;
    desc.max_iterations = iterations;
    desc.tolerance = tolerance;
    desc.reduce = VDBS_REDUCE_MAX;
    desc.gpu_chunk = gpu_chunk;
    return desc;
}

/* Runs up to `iterations` steps from u = 0 on the runner into u. */
static vdbs_status solve(vdbs_runner *runner, int iterations, double tolerance, uint64_t gpu_chunk,
                         float *u, vdbs_kernel_result *result, vdbs_error *err)
{
    memset(u, 0, sizeof(float) * ITEMS);
    vdbs_kernel_desc desc = jacobi_desc(iterations, tolerance, gpu_chunk, u);
    return vdbs_kernel_iterate(runner, &desc, result, err);
}

/* After k steps: the field is (1 - rho^k) u* and the last step's change rho^(k-1)(1-rho) peak. */
static void check_closed_form(vdbs_backend backend, uint64_t gpu_chunk)
{
    const int k = 60;
    float *u = malloc(sizeof(float) * ITEMS);
    vdbs_kernel_result result;
    vdbs_error err;
    if (solve(test_runner(backend), k, 0.0, gpu_chunk, u, &result, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(result.iterations, k);
    double worst = 0.0;
    for (int m = 0; m < ITEMS; ++m)
        worst = fmax(worst, fabs(u[m] - (1.0 - pow(P.rho, k)) * P.exact[m]));
    double change = pow(P.rho, k - 1) * (1.0 - P.rho) * P.peak;
    print_message("%s: %d steps, rho %.6f, field error %.2e of peak, last change %.6e "
                  "(closed form %.6e)\n",
                  backend == VDBS_BACKEND_GPU ? "GPU" : "C", k, P.rho, worst / P.peak,
                  result.reduction, change);
    /* Float rounding of 60 steps of 7-term sums: far below 1e-5 of the peak. */
    assert_true(worst <= 1e-5 * P.peak);
    assert_true(fabs(result.reduction - change) <= 1e-3 * change);
    if (backend == VDBS_BACKEND_GPU)
        assert_int_equal(result.dispatches, k);
    free(u);
}

/* The C path's thread counts; on more threads than cores the waiting threads yield. */
static const int C_THREADS[] = {1, 2, 4};
#define C_THREAD_COUNTS (int)(sizeof C_THREADS / sizeof *C_THREADS)

static void test_closed_form_c(void **state)
{
    (void)state;
    const int before = omp_get_max_threads();
    for (int t = 0; t < C_THREAD_COUNTS; ++t) {
        omp_set_num_threads(C_THREADS[t]);
        print_message("C on %d threads:\n", C_THREADS[t]);
        check_closed_form(VDBS_BACKEND_CPU, 0);
    }
    omp_set_num_threads(before);
}

static void test_closed_form_gpu(void **state)
{
    (void)state;
    check_closed_form(VDBS_BACKEND_GPU, 0);
    /* Several dispatch calls per step: the partials of every chunk land in their place. */
    check_closed_form(VDBS_BACKEND_GPU, 256);
}

/* The tolerance stops the loop at the first step whose change is below it. */
static void test_tolerance_stops(void **state)
{
    (void)state;
    const double tolerance = 1e-3 * P.peak;
    /* Smallest k with rho^(k-1) (1 - rho) peak <= tolerance. */
    int expected = 1 + (int)ceil(log(tolerance / ((1.0 - P.rho) * P.peak)) / log(P.rho));
    const vdbs_backend backends[2] = {VDBS_BACKEND_CPU, VDBS_BACKEND_GPU};
    float *u = malloc(sizeof(float) * ITEMS);
    for (int b = 0; b < 2; ++b) {
        vdbs_kernel_result result;
        vdbs_error err;
        if (solve(test_runner(backends[b]), 100000, tolerance, 0, u, &result, &err) != VDBS_OK)
            fail_msg("%s", err.message);
        print_message("%s: stopped after %d steps (closed form %d), change %.3e <= %.3e\n",
                      b ? "GPU" : "C", result.iterations, expected, result.reduction, tolerance);
        assert_true(result.reduction <= tolerance);
        assert_true(abs(result.iterations - expected) <= 1);
    }
    free(u);
}

static vdbs_status run_steps(vdbs_runner *runner, const void *scenario, float *out, vdbs_error *err)
{
    vdbs_kernel_result result;
    return solve(runner, *(const int *)scenario, 0.0, 0, out, &result, err);
}

/* The same 300 steps on both backends, field against field (the twin harness). */
static void test_twins(void **state)
{
    (void)state;
    const int steps = 300;
    free(test_twin("jacobi, 300 steps", run_steps, &steps, ITEMS));
}

static double sweep_step(void *user, int step, const void *state_in, void *state_out,
                         uint64_t begin, uint64_t end)
{
    const float *rhs = user;
    const float *in = state_in;
    float *out = state_out;
    double sum = 0.0;
    for (uint64_t n = begin; n < end; ++n) {
        float u = vs_sweep_item(in, rhs, (int)n, PLANE, step);
        out[n + (uint64_t)step * PLANE] = u;
        sum += u;
    }
    return sum;
}

/* In-place sweep, plane after plane along z: with f = 1, plane k holds 2 - 2^-k exactly
 * (binary fractions) and sums to PLANE times that. Steps out of order, or without a
 * barrier between them, read a plane that is not written yet; planes beyond the last step
 * stay untouched. */
static void test_sweep_in_place(void **state)
{
    (void)state;
    static float rhs[ITEMS];
    for (int m = 0; m < ITEMS; ++m)
        rhs[m] = 1.0f;
    /* The C path on each thread count, then the GPU. */
    const int runs = C_THREAD_COUNTS + 1, before = omp_get_max_threads();
    const int steps[3] = {1, 5, NZ};
    float *u = malloc(sizeof(float) * ITEMS);
    for (int r = 0; r < runs; ++r)
        for (int t = 0; t < 3; ++t) {
            const int b = r == C_THREAD_COUNTS;
            omp_set_num_threads(b ? before : C_THREADS[r]);
            memset(u, 0, sizeof(float) * ITEMS);
            vdbs_kernel_desc desc = {0};
            desc.items = PLANE;
            desc.user = rhs;
            desc.cpu_step = sweep_step;
            desc.cpu_chunk = 10; /* 14 chunks a step for the threads to share */
            desc.shader = "test_sweep.comp";
            desc.inputs[1] = (vdbs_kernel_input){.data = rhs, .size = sizeof rhs};
            desc.state = u;
            desc.state_items = ITEMS;
            desc.in_place = 1;
            desc.max_iterations = steps[t];
            desc.reduce = VDBS_REDUCE_SUM;
            vdbs_kernel_result result;
            vdbs_error err;
            if (vdbs_kernel_iterate(test_runner(b ? VDBS_BACKEND_GPU : VDBS_BACKEND_CPU), &desc,
                                    &result, &err) != VDBS_OK)
                fail_msg("%s", err.message);
            assert_int_equal(result.iterations, steps[t]);
            for (int k = 0; k < NZ; ++k) {
                float want = k < steps[t] ? (float)(2.0 - ldexp(1.0, -k)) : 0.0f;
                for (int n = 0; n < PLANE; ++n)
                    if (u[n + k * PLANE] != want)
                        fail_msg("%s (%d threads), %d steps: plane %d item %d is %.9g, want %.9g",
                                 b ? "GPU" : "C", omp_get_max_threads(), steps[t], k, n,
                                 u[n + k * PLANE], want);
            }
            double last = PLANE * (2.0 - ldexp(1.0, -(steps[t] - 1)));
            print_message("%s (%d threads): %d in-place steps exact; last plane sum %.9g (exact "
                          "%.9g)\n",
                          b ? "GPU" : "C", omp_get_max_threads(), steps[t], result.reduction, last);
            assert_true(fabs(result.reduction - last) <= 1e-6 * last);
        }
    omp_set_num_threads(before);
    free(u);
}

/* What the runner moved while `desc` ran on it from u = 0: the field (compared bitwise with
 * `want` when given) and the change of its counters. */
static vdbs_runner_transfer moved_by(vdbs_runner *runner, vdbs_kernel_desc *desc, float *u,
                                     const float *want, vdbs_kernel_result *result)
{
    vdbs_runner_transfer before = vdbs_runner_transfers(runner);
    memset(u, 0, sizeof(float) * ITEMS);
    vdbs_error err;
    if (vdbs_kernel_iterate(runner, desc, result, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (want && memcmp(u, want, sizeof(float) * ITEMS) != 0)
        fail_msg("the field changed with how the inputs travelled");
    vdbs_runner_transfer after = vdbs_runner_transfers(runner);
    return (vdbs_runner_transfer){after.uploaded - before.uploaded,
                                  after.read_back - before.read_back,
                                  after.resident_uploaded - before.resident_uploaded};
}

static void assert_moved(const char *label, vdbs_runner_transfer t, unsigned long long uploaded,
                         unsigned long long read_back, unsigned long long resident)
{
    print_message("%s: uploaded %llu (want %llu), read back %llu (want %llu), resident %llu "
                  "(want %llu)\n",
                  label, t.uploaded, uploaded, t.read_back, read_back, t.resident_uploaded,
                  resident);
    assert_true(t.uploaded == uploaded);
    assert_true(t.read_back == read_back);
    assert_true(t.resident_uploaded == resident);
}

/* The transfer counters, exactly, for 60 Jacobi steps: on the GPU the inputs and the initial
 * state up once, a control block up and back and the group partials back per step, the final
 * state back; a resident input uploaded by the first call only; no partials without a
 * reduction and no initial state when it starts zeroed; nothing at all on the C path. */
static void test_transfer_counts(void **state)
{
    (void)state;
    const int k = 60;
    const unsigned long long control = sizeof(uint32_t) * VS_PASS_WORDS;
    const unsigned long long partials =
        sizeof(float) * ((ITEMS + VS_PASS_LOCAL_SIZE - 1) / VS_PASS_LOCAL_SIZE);
    const unsigned long long field = sizeof(float) * ITEMS;
    const unsigned long long inputs = sizeof P.rhs + sizeof P.dims;
    float *u = malloc(sizeof(float) * ITEMS), *want = malloc(sizeof(float) * ITEMS);
    assert_non_null(u);
    assert_non_null(want);
    vdbs_runner *gpu = test_runner(VDBS_BACKEND_GPU);
    vdbs_kernel_result result;
    vdbs_kernel_desc desc = jacobi_desc(k, 0.0, 0, u);
    assert_moved("per-call inputs", moved_by(gpu, &desc, u, NULL, &result),
                 inputs + field + k * control, k * (control + partials) + field, 0);
    memcpy(want, u, sizeof(float) * ITEMS);
    const double reduction = result.reduction;

    desc.inputs[1].resident = vdbs_runner_resident_id(gpu);
    assert_moved("resident rhs, first call", moved_by(gpu, &desc, u, want, &result),
                 inputs + field + k * control, k * (control + partials) + field, sizeof P.rhs);
    assert_moved("resident rhs, second call", moved_by(gpu, &desc, u, want, &result),
                 sizeof P.dims + field + k * control, k * (control + partials) + field, 0);
    assert_true(result.reduction == reduction);

    desc.reduce = VDBS_REDUCE_NONE;
    desc.state_zeroed = 1;
    assert_moved("no reduction, zeroed state", moved_by(gpu, &desc, u, want, &result),
                 sizeof P.dims + k * control, k * control + field, 0);
    assert_true(result.reduction == 0.0 && result.iterations == k);
    vdbs_runner_release(gpu, desc.inputs[1].resident);

    vdbs_runner *cpu = test_runner(VDBS_BACKEND_CPU);
    desc.inputs[1].resident = vdbs_runner_resident_id(cpu);
    assert_moved("C path", moved_by(cpu, &desc, u, NULL, &result), 0, 0, 0);
    free(u);
    free(want);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closed_form_c),   cmocka_unit_test(test_closed_form_gpu),
        cmocka_unit_test(test_tolerance_stops), cmocka_unit_test(test_twins),
        cmocka_unit_test(test_sweep_in_place),  cmocka_unit_test(test_transfer_counts),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
