/* Solvers as a table: each bake method is one entry (name, summary, run function). Adding a
 * solver is adding an entry to the table in solver.c plus its kernels. */
#ifndef VDBSCATTER_SOLVER_H
#define VDBSCATTER_SOLVER_H

#include <stddef.h>

#include "vdbscatter/quality.h"
#include "vdbscatter/solve.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbs_method {
    VDBS_METHOD_SINGLE = 0,
    VDBS_METHOD_POP,
    VDBS_METHOD_FLD,
    VDBS_METHOD_SVD,
    VDBS_METHOD_COUNT
} vdbs_method;

typedef struct vdbs_solver {
    vdbs_method method;
    const char *name;    /* --method */
    const char *summary; /* one line for --help */
    int writes_ms;       /* 0: ms and ms_l1 stay 0 (the bake then shares one zero array) */
    vdbs_status (*run)(const vdbs_solve *solve, vdbs_error *err);
} vdbs_solver;

/* The solver of a method name, or NULL if none is implemented under that name. */
const vdbs_solver *vdbs_solver_find(const char *name);
/* The implemented solvers, in table order. */
const vdbs_solver *vdbs_solver_list(int *count);
/* "single" or "single, pop" ...: the names for messages. */
void vdbs_solver_names(char *buf, size_t size);

#ifdef __cplusplus
}
#endif

#endif
