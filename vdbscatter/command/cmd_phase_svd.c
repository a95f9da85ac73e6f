/* vdbscatter phase-svd: the factorisation error of the discrete HG phase matrix per number of
 * terms (vdbscatter/phasemat.h; the paper's Fig. 3). */
#include <stdio.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "options.h"
#include "vdbscatter/phasemat.h"

static const char help[] =
    "usage: vdbscatter phase-svd --g G --directions D [--delta-m auto|on|off] [--json]\n"
    "\n"
    "Builds the D x D discrete phase matrix of the Henyey-Greenstein phase of anisotropy G\n"
    "on D directions spread evenly over the sphere (symmetric, every column summing to 1),\n"
    "factorises it (symmetric eigendecomposition, terms in order of |eigenvalue|) and\n"
    "prints the relative RMSE ||P - P_N|| / ||P|| (Frobenius) for every N from 1 to D.\n"
    "Where D directions cannot resolve the forward peak, delta-M scaling moves the peak\n"
    "fraction f into the unscattered beam and the matrix is that of the truncated phase\n"
    "(g*); both are printed.\n"
    "\n"
    "options:\n"
    "  --g G               HG anisotropy in (-1, 1) (required)\n"
    "  --directions D      2..16384 (required)\n"
    "  --delta-m MODE      auto (default: when the quadrature's sums are off by > 1%),\n"
    "                      on or off\n"
    "  --json              print {\"g\", \"directions\", \"delta_m_f\", \"g_scaled\", \"rows\":\n"
    "                      [{\"terms\", \"rmse\"}, ...]}\n";

static const vdbs_arg_option options[] = {
    {"--g", VDBS_ARG_VALUE},       {"--directions", VDBS_ARG_VALUE},
    {"--delta-m", VDBS_ARG_VALUE}, {"--json", VDBS_ARG_FLAG},
    {NULL, VDBS_ARG_FLAG},
};

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .run = run,
    .name = "phase-svd",
    .options = options,
    .help = help,
    .max_positional = 0,
    .positional_error = "takes no positional arguments",
};

static int run(const vdbs_options_args *args)
{
    vdbs_error err;
    const char *gv = vdbs_options_value(args, "--g"),
               *dv = vdbs_options_value(args, "--directions");
    if (!gv || !dv)
        return vdbs_command_fail("phase-svd", 2, "--g and --directions are required");
    double g = 0.0;
    long d = 0;
    vdbs_phasemat_desc desc = {0};
    if (vdbs_options_number("--g", gv, &g, &err) != VDBS_OK ||
        vdbs_options_integer("--directions", dv, 2, VDBS_PHASEMAT_MAX_DIRECTIONS, &d, &err) !=
            VDBS_OK)
        return vdbs_command_fail("phase-svd", 2, err.message);
    const char *mode = vdbs_options_value(args, "--delta-m");
    if (mode) {
        static const char *const names[3] = {"off", "auto", "on"};
        int found = 0;
        for (int k = 0; k < 3; ++k)
            if (strcmp(mode, names[k]) == 0) {
                desc.delta_m = k - 1;
                found = 1;
            }
        if (!found)
            return vdbs_command_fail("phase-svd", 2, "--delta-m: expected auto, on or off");
    }
    desc.directions = (int)d;
    desc.g = g;
    vdbs_phasemat m;
    vdbs_status st = vdbs_phasemat_build(&desc, &m, &err);
    if (st != VDBS_OK)
        return vdbs_command_fail("phase-svd", st, err.message);
    if (vdbs_options_flag(args, "--json")) {
        cJSON *j = cJSON_CreateObject(), *rows = NULL;
        cJSON_AddNumberToObject(j, "g", g);
        cJSON_AddNumberToObject(j, "directions", (double)d);
        cJSON_AddNumberToObject(j, "delta_m_f", m.f);
        cJSON_AddNumberToObject(j, "g_scaled", m.g_scaled);
        rows = cJSON_AddArrayToObject(j, "rows");
        for (int n = 1; n <= m.d; ++n) {
            cJSON *row = cJSON_CreateObject();
            cJSON_AddNumberToObject(row, "terms", n);
            cJSON_AddNumberToObject(row, "rmse", vdbs_phasemat_rmse(&m, n));
            cJSON_AddItemToArray(rows, row);
        }
        char *text = cJSON_PrintUnformatted(j);
        vdbs_command_out("%s\n", text);
        cJSON_free(text);
        cJSON_Delete(j);
    } else {
        vdbs_command_out("g %g, %ld directions, delta-M f %g (g* %g)\nterms rmse\n", g, d, m.f,
                         m.g_scaled);
        for (int n = 1; n <= m.d; ++n)
            vdbs_command_out("%d %.6g\n", n, vdbs_phasemat_rmse(&m, n));
    }
    vdbs_phasemat_free(&m);
    return VDBS_EXIT_OK;
}

const vdbs_command_spec *vdbs_command_phase_svd(void)
{
    return &command;
}
