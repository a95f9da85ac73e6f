/* A solver that never ships: single scattering times a constant, with one option. It is
 * the test that adding a solver touches only its own file and one line that lists it: here
 * vdbs_solver_register in main() stands for that line. The executable is the whole command
 * line (cli/main.c with its main renamed, tests/CMakeLists.txt), so bake's --help, the scene
 * key, the JSON report and the lit VDB's metadata all meet the toy's option as they meet a
 * real solver's (tests/test_toy_solver_cli.py). */
#include <stddef.h>
#include <stdio.h>

#include "vdbscatter/solve.h"
#include "vdbscatter/solver.h"

int vdbscatter_cli_main(int argc, char **argv);

enum { OPT_FACTOR };

static const vdbs_solver_option options[] = {
    [OPT_FACTOR] = {.key = "toy_factor",
                    .flag = "--toy-factor",
                    .kind = VDBS_OPTION_NUMBER,
                    .syntax = "F",
                    .min = 0,
                    .max = 100,
                    .help = "TOY: multiplies single scattering by F (default 2 at low,\n"
                            "3 at medium, 4 at high, 5 at ultra)",
                    .preset = {2, 3, 4, 5}},
};

typedef struct toy_stats {
    double factor;
    double voxels;
} toy_stats;

static vdbs_status run_toy(const vdbs_solve *s, void *stats, vdbs_error *err)
{
    const float factor =
        (float)vdbs_solver_option_value(s->scene, &options[OPT_FACTOR], s->quality);
    vdbs_status st = vdbs_solve_s1(s, NULL, NULL, err);
    for (size_t i = 0; st == VDBS_OK && i < 3 * s->volume->coord_count; ++i) {
        s->radiance[i] *= factor;
        if (s->radiance_view)
            s->radiance_view[i] *= factor;
    }
    toy_stats *t = stats;
    t->factor = factor;
    t->voxels = (double)s->volume->coord_count;
    return st;
}

static const vdbs_report_field report[] = {
    {"factor", VDBS_REPORT_DOUBLE, offsetof(toy_stats, factor)},
    {"voxels", VDBS_REPORT_DOUBLE, offsetof(toy_stats, voxels)},
};

static void report_text(const void *stats, char *text, size_t size)
{
    snprintf(text, size, "factor %g", ((const toy_stats *)stats)->factor);
}

static const vdbs_solver toy = {
    .name = "toy",
    .summary = "single scattering times a constant (a test solver)",
    .writes_ms = 0,
    .options = options,
    .option_count = 1,
    .run = run_toy,
    .stats_size = sizeof(toy_stats),
    .report = report,
    .report_count = 2,
    .report_text = report_text,
    .cost = {1, 1, 1, 1},
};

int main(int argc, char **argv)
{
    vdbs_error err;
    if (vdbs_solver_register(&toy, &err) != VDBS_OK) {
        fprintf(stderr, "vdbscatter-toy: %s\n", err.message);
        return 1;
    }
    return vdbscatter_cli_main(argc, argv);
}
