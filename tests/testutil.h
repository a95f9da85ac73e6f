/* Shared helpers for the C tests (cmocka). */
#ifndef VDBS_TESTUTIL_H
#define VDBS_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "vdbscatter/render.h"
#include "vdbscatter/scene.h"

/* Path inside the shared data folder / the test temp folder (static buffer per call slot). */
const char *test_data_path(const char *file);
const char *test_tmp_path(const char *file);

/* Relative difference |a-b| / max(|a|,|b|), 0 when both are 0. */
double test_rel_diff(double a, double b);

/* The lights the CPU/GPU agreement tests share: a sun travelling along (0.3,-1,0.2) of
 * irradiance 3, a coloured point light at (0.5,1.2,-0.3) and a constant blue sky. */
void test_add_sun_point_sky(vdbs_scene *scene);

/* Loads the ms / ms_l1* grids of a lit VDB written by a test, then removes the file;
 * fails the test on any error. */
void test_load_ms_grids(const char *path, const double index_to_world[3][4], vdbs_ms_grids *ms);

#endif
