/* The solvers' own flags (--pop-res, --fld-limiter, --residual ...), from the library's
 * solver table: each entry declares its options, and the command line takes them from
 * there (solver.h). */
#ifndef VDBSCATTER_CLI_SOLVER_FLAGS_H
#define VDBSCATTER_CLI_SOLVER_FLAGS_H

#include <stdio.h>

#include "options.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"

/* Appends every solver option's flag to a command's option table of `count` entries (room
 * for `max`, the terminating {NULL} entry included) and terminates it; returns the new count. */
int cli_solver_flags_add(cli_option *options, int count, int max);

/* Applies `name VALUE` if name is a solver's flag: *handled 1, and the value checked against
 * the option's range (errors name the flag); *handled 0 for any other name. */
vdbs_status cli_solver_flag(const char *name, const char *value, vdbs_scene *scene, int *handled,
                            vdbs_error *err);

/* bake --help's list of methods and each one's options. */
void cli_solver_help(FILE *out);

#endif
