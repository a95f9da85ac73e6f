/* Shared helpers for the C tests (cmocka). */
#ifndef VDBS_TESTUTIL_H
#define VDBS_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "vdbscatter/runner.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/single.h"

/* Path inside the external test data folder / the test temp folder (static buffer per call
 * slot). Without the data folder (configured empty), test_data_path skips the calling test. */
const char *test_data_path(const char *file);
const char *test_tmp_path(const char *file);

/* Writes the first `keep` (0..1) of file `from` (under 128 KiB) to `to`: a truncated file. */
void test_truncated_copy(const char *from, const char *to, double keep);

/* Relative difference |a-b| / max(|a|,|b|), 0 when both are 0. */
double test_rel_diff(double a, double b);

/* qsort's comparison of doubles, ascending. */
int test_compare_doubles(const void *a, const void *b);

/* The lights the CPU/GPU agreement tests share: a sun travelling along (0.3,-1,0.2) of
 * irradiance 3, a coloured point light at (0.5,1.2,-0.3) and a constant blue sky. */
void test_add_sun_point_sky(vdbs_scene *scene);

/* Loads the ms / ms_l1* grids of a lit VDB written by a test, then removes the file;
 * fails the test on any error. */
void test_load_ms_grids(const char *path, const double index_to_world[3][4], vdbs_lit_grids *ms);

/* Writes a lit VDB over the volume's output voxels whose radiance and ms grids are `ms`
 * and whose ms_l1x/y/z are l1[0..2] (3 floats per voxel each); fails the test on error. */
void test_write_lit(const char *path, const vdbs_volume *volume, const float *ms,
                    float *const l1[3]);

/* A volume from dense values (vdbio_density_from_dense, grid "density"); frees `values`;
 * fails the test on error. */
void test_dense_volume(float *values, const int dims[3], const int origin[3],
                       const vdbio_transform *xf, vdbs_volume *volume);

/* A procedural sample volume (vdbs_sample_create); fails the test on error. */
void test_sample_volume(const char *name, int res, unsigned seed, vdbs_volume *volume);

/* The runner of a backend, created on first use and kept for the test program; fails the
 * test when it cannot be created. */
vdbs_runner *test_runner(vdbs_backend backend);
void test_runners_free(void);

/* The single-scattering pass of a scene with `sky` sky ordinates on a runner. */
vdbs_status test_single_scatter(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, int sky, float *radiance, vdbs_error *err);

/* The CPU/GPU twin harness (one test text, two implementations): a scenario writes n
 * floats on the runner it is given. test_twin runs it on the C path and on the GPU and
 * asserts that both are finite and non-negative and agree to 1e-5 relative wherever
 * either |v| >= 1e-30 (docs/design.md: llvmpipe's exp/pow, FMA and denormals differ from gcc's),
 * with more than half the values compared. Returns the C output (the caller frees it). */
typedef vdbs_status (*test_twin_fn)(vdbs_runner *runner, const void *scenario, float *out,
                                    vdbs_error *err);
/* The next value in [0, 1) of a 64-bit LCG (state updated): fixed pseudo-random inputs. */
double test_uniform(uint64_t *state);

float *test_twin(const char *label, test_twin_fn run, const void *scenario, size_t n);

/* n-point Gauss-Legendre nodes x and weights w on [a, b] (Newton on the Legendre recurrence,
 * to 1e-15). */
void test_gauss_legendre(int n, double a, double b, double *x, double *w);

#endif
