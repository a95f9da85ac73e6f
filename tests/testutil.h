/* Shared helpers for the C tests (cmocka). */
#ifndef VDBS_TESTUTIL_H
#define VDBS_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

/* Path inside the shared data folder / the test temp folder (static buffer per call slot). */
const char *test_data_path(const char *file);
const char *test_tmp_path(const char *file);

/* Relative difference |a-b| / max(|a|,|b|), 0 when both are 0. */
double test_rel_diff(double a, double b);

#endif
