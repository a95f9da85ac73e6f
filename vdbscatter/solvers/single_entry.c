/* The single-scattering solver's entry (solver.h): S1 only, no options. */
#include "vdbscatter/solve.h"
#include "vdbscatter/solver.h"

/* Single scattering only; ms and its moments stay 0. */
static vdbs_status run_single(const vdbs_solve *s, void *stats, vdbs_error *err)
{
    (void)stats;
    return vdbs_solve_s1(s, NULL, NULL, err);
}

const vdbs_solver vdbs_solver_single = {
    .name = "single",
    .summary = "exact single scattering only (no multiple scattering)",
    .writes_ms = 0,
    .run = run_single,
    .cost = {4.79, 17.4, 256, 1e+03}, /* bench/cost.md */
};
