/* Tests of the OpenVDB bridge (vdbio.cpp) on generated grids and on the real files
 * in the shared data folder. */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vdbscatter/vdbio.h"

typedef struct warnings {
    int count;
    char last[1024];
} warnings;

static void collect_warning(void *user, const char *message)
{
    warnings *w = user;
    w->count++;
    snprintf(w->last, sizeof w->last, "%s", message);
}

static vdbio_read_options options(warnings *w)
{
    vdbio_read_options o;
    memset(&o, 0, sizeof o);
    o.warn = collect_warning;
    o.warn_user = w;
    return o;
}

static vdbio_density *read_ok(const char *file, const vdbio_read_options *o)
{
    vdbio_density *d = NULL;
    vdbs_error err;
    /* The call must succeed whatever message the error struct held before. */
    vdbs_error_set(&err, VDBS_OK, "stale");
    vdbs_status st = vdbio_density_read(test_data_path(file), o, &d, &err);
    if (st != VDBS_OK)
        fail_msg("%s: %s", file, err.message);
    assert_non_null(d);
    return d;
}

/* Reads a file that must fail with VDBS_ERR_INPUT and a message containing `expect`. */
static void read_fails(const char *path, const vdbio_read_options *o, const char *expect)
{
    vdbio_density *d = NULL;
    vdbs_error err = {{0}};
    vdbs_status st = vdbio_density_read(path, o, &d, &err);
    if (st != VDBS_ERR_INPUT)
        fail_msg("%s: status %d, message '%s'", path, st, err.message);
    assert_null(d);
    if (!strstr(err.message, expect))
        fail_msg("%s: message '%s' lacks '%s'", path, err.message, expect);
    assert_null(strchr(err.message, '\n'));
    assert_true(strlen(err.message) < 600);
    /* The message names the file. */
    const char *base = strrchr(path, '/');
    assert_non_null(strstr(err.message, base ? base + 1 : path));
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* No ".NAME.tmp.PID" file of this process may be left behind in the test folder (the folder is
 * shared with tests running beside this one, whose writes have temp files of their own). */
static int temp_files_left(void)
{
    int n = 0;
    char own[32];
    snprintf(own, sizeof own, ".tmp.%ld", (long)getpid());
    DIR *dir = opendir(test_tmp_path(""));
    assert_non_null(dir);
    struct dirent *e;
    while ((e = readdir(dir))) {
        const char *tmp = strstr(e->d_name, own);
        if (e->d_name[0] == '.' && tmp && tmp[strlen(own)] == '\0')
            n++;
    }
    closedir(dir);
    return n;
}

static void copy_prefix(const char *src, const char *dst, long bytes)
{
    FILE *in = fopen(src, "rb");
    assert_non_null(in);
    FILE *out = fopen(dst, "wb");
    assert_non_null(out);
    char buf[65536];
    long left = bytes;
    while (left > 0) {
        size_t want = left < (long)sizeof buf ? (size_t)left : sizeof buf;
        size_t got = fread(buf, 1, want, in);
        assert_true(got > 0);
        assert_int_equal(fwrite(buf, 1, got, out), got);
        left -= (long)got;
    }
    fclose(in);
    fclose(out);
}

static long file_size(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return (long)st.st_size;
}

/* A rotated, non-uniformly scaled, translated map. */
static vdbio_transform skewed_transform(void)
{
    const double c = cos(0.3), s = sin(0.3);
    vdbio_transform t = {
        {{0.5 * c, -0.25 * s, 0.0, 1.5}, {0.5 * s, 0.25 * c, 0.0, -2.0}, {0.0, 0.0, 0.125, 0.75}}};
    return t;
}

static float dense_value(int i, int j, int k)
{
    /* Some zeros and negatives (inactive), exact dyadic positives otherwise. */
    int h = (i * 7 + j * 3 + k * 5) % 9;
    return h < 3 ? (float)(h - 2) : (float)h * 0.375f + (float)i * 0.0625f;
}

enum { NX = 11, NY = 7, NZ = 9 };
static const int dense_origin[3] = {-3, 2, 10};

static vdbio_density *make_dense(uint64_t *active)
{
    static float values[NX * NY * NZ];
    uint64_t n = 0;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                float v = dense_value(i, j, k);
                values[(k * NY + j) * NX + i] = v;
                n += v > 0.0f;
            }
    const int dims[3] = {NX, NY, NZ};
    vdbio_transform t = skewed_transform();
    vdbio_density *d = NULL;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_from_dense(values, dims, dense_origin, &t, "cloud", &d, &err),
                     VDBS_OK);
    *active = n;
    return d;
}

static void vec3_value(const int32_t *c, int g, float out[3])
{
    out[0] = (float)c[0] * 0.5f + (float)g;
    out[1] = (float)c[1] * 0.25f - 3.0f;
    out[2] = (float)c[2] * 0.125f + 0.5f * (float)g;
}

static void test_from_dense_info(void **state)
{
    (void)state;
    uint64_t active;
    vdbio_density *d = make_dense(&active);
    const vdbio_density_info *info = vdbio_density_get_info(d);
    assert_string_equal(info->name, "cloud");
    assert_string_equal(info->source_type, "float");
    assert_int_equal(info->active_voxels, active);
    assert_int_equal(info->active_tiles, 0);
    vdbio_transform t = skewed_transform();
    assert_memory_equal(&info->transform, &t, sizeof t);
    assert_true(fabs(info->voxel_size[0] - 0.5) < 1e-12);
    assert_true(fabs(info->voxel_size[1] - 0.25) < 1e-12);
    assert_true(fabs(info->voxel_size[2] - 0.125) < 1e-12);
    assert_int_equal(info->bbox_min[0], dense_origin[0]);
    assert_int_equal(info->bbox_max[0], dense_origin[0] + NX - 1);
    assert_int_equal(info->bbox_min[2], dense_origin[2]);
    assert_int_equal(info->bbox_max[2], dense_origin[2] + NZ - 1);
    float vmin = 1e30f, vmax = 0.0f;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                float v = dense_value(i, j, k);
                int ijk[3] = {i + dense_origin[0], j + dense_origin[1], k + dense_origin[2]};
                assert_true(vdbio_density_value(d, ijk) == (v > 0.0f ? v : 0.0f));
                if (v > 0.0f) {
                    vmin = fminf(vmin, v);
                    vmax = fmaxf(vmax, v);
                }
            }
    assert_true(info->value_min == vmin);
    assert_true(info->value_max == vmax);
    vdbio_density_free(d);

    /* All zero: an empty grid is allowed here; NaN is not. */
    float zeros[8] = {0};
    const int dims2[3] = {2, 2, 2};
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_from_dense(zeros, dims2, NULL, NULL, NULL, &d, &err), VDBS_OK);
    assert_int_equal(vdbio_density_get_info(d)->active_voxels, 0);
    assert_int_equal(vdbio_density_get_info(d)->bbox_max[0], -1);
    assert_string_equal(vdbio_density_get_info(d)->name, "density");
    vdbio_density_free(d);
    zeros[5] = NAN;
    assert_int_equal(vdbio_density_from_dense(zeros, dims2, NULL, NULL, NULL, &d, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "NaN"));
    assert_null(d);
    vdbio_transform singular = {{{1, 0, 0, 0}, {1, 0, 0, 0}, {0, 0, 1, 0}}};
    zeros[5] = 1.0f;
    assert_int_equal(vdbio_density_from_dense(zeros, dims2, NULL, &singular, NULL, &d, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "singular"));
}

static vdbio_density *single_voxel_block(int n)
{
    float v[8] = {1, 1, 1, 1, 1, 1, 1, 1};
    const int dims[3] = {n, n, n};
    const int origin[3] = {5, -6, 7};
    vdbio_density *d = NULL;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_from_dense(v, dims, origin, NULL, NULL, &d, &err), VDBS_OK);
    return d;
}

static size_t coord_count(const vdbio_density *d, int dilation)
{
    int32_t *coords = NULL;
    size_t n = 0;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_output_coords(d, dilation, &coords, &n, &err), VDBS_OK);
    free(coords);
    return n;
}

static void test_output_coords(void **state)
{
    (void)state;
    vdbio_density *one = single_voxel_block(1);
    assert_int_equal(coord_count(one, 0), 1);
    assert_int_equal(coord_count(one, 1), 27);
    assert_int_equal(coord_count(one, 2), 125);
    int32_t *coords = NULL;
    size_t n = 0;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_output_coords(one, 1, &coords, &n, &err), VDBS_OK);
    /* Exactly the 3x3x3 neighbourhood of (5,-6,7), each voxel once. */
    int seen[27] = {0};
    for (size_t i = 0; i < n; i++) {
        int dx = coords[3 * i] - 5, dy = coords[3 * i + 1] + 6, dz = coords[3 * i + 2] - 7;
        assert_true(abs(dx) <= 1 && abs(dy) <= 1 && abs(dz) <= 1);
        seen[(dz + 1) * 9 + (dy + 1) * 3 + dx + 1]++;
    }
    for (int i = 0; i < 27; i++)
        assert_int_equal(seen[i], 1);
    free(coords);
    assert_int_equal(vdbio_density_output_coords(one, -1, &coords, &n, &err), VDBS_ERR_INTERNAL);
    vdbio_density_free(one);

    vdbio_density *block = single_voxel_block(2);
    assert_int_equal(coord_count(block, 0), 8);
    assert_int_equal(coord_count(block, 1), 64);
    assert_int_equal(coord_count(block, 3), 512);
    vdbio_density_free(block);
}

static int write_lit(const char *path, const vdbio_density *d, int half, warnings *w,
                     int32_t **coords_out, size_t *count_out, float **values_out, vdbs_error *err)
{
    int32_t *coords = NULL;
    size_t n = 0;
    assert_int_equal(vdbio_density_output_coords(d, 1, &coords, &n, err), VDBS_OK);
    float *values = malloc(2 * 3 * n * sizeof(float));
    assert_non_null(values);
    for (size_t i = 0; i < n; i++)
        for (int g = 0; g < 2; g++)
            vec3_value(coords + 3 * i, g, values + (size_t)g * 3 * n + 3 * i);
    vdbio_vec3_grid grids[2] = {{"radiance", values}, {"ms", values + 3 * n}};
    vdbio_meta meta[2] = {{"vdbscatter_method", "pop"}, {"vdbscatter_scene", "{\"a\": 1}"}};
    vdbio_write_request req;
    memset(&req, 0, sizeof req);
    req.density = d;
    req.coords = coords;
    req.coord_count = n;
    req.vec3_grids = grids;
    req.vec3_grid_count = 2;
    req.file_meta = meta;
    req.file_meta_count = 2;
    req.half = half;
    req.warn = collect_warning;
    req.warn_user = w;
    int st = vdbio_write(path, NULL, &req, err);
    *coords_out = coords;
    *count_out = n;
    *values_out = values;
    return st;
}

static void test_round_trip(void **state)
{
    (void)state;
    uint64_t active;
    vdbio_density *d = make_dense(&active);
    const char *path = test_tmp_path("vdbio_round_trip.vdb");
    unlink(path);
    warnings w = {0};
    int32_t *coords;
    size_t n;
    float *values;
    vdbs_error err = {{0}};
    assert_int_equal(write_lit(path, d, 0, &w, &coords, &n, &values, &err), VDBS_OK);
    assert_int_equal(w.count, 0);
    assert_true(n > active);
    assert_int_equal(temp_files_left(), 0);

    vdbio_lit *lit = NULL;
    assert_int_equal(vdbio_lit_open(path, &lit, &err), VDBS_OK);
    assert_true(vdbio_lit_has_grid(lit, "density"));
    assert_true(vdbio_lit_has_grid(lit, "radiance"));
    assert_true(vdbio_lit_has_grid(lit, "ms"));
    assert_false(vdbio_lit_has_grid(lit, "ms_l1x"));

    /* Density: identical at every voxel of the dense box and one voxel around it. */
    for (int k = -1; k <= NZ; k++)
        for (int j = -1; j <= NY; j++)
            for (int i = -1; i <= NX; i++) {
                int ijk[3] = {i + dense_origin[0], j + dense_origin[1], k + dense_origin[2]};
                float got = -1.0f;
                assert_int_equal(vdbio_lit_float(lit, "density", ijk, &got, &err), VDBS_OK);
                float want = vdbio_density_value(d, ijk);
                assert_memory_equal(&got, &want, sizeof got);
            }
    /* vec3 grids: identical at every output voxel, zero elsewhere. */
    for (size_t i = 0; i < n; i++) {
        for (int g = 0; g < 2; g++) {
            float got[3];
            assert_int_equal(vdbio_lit_vec3(lit, g ? "ms" : "radiance", coords + 3 * i, got, &err),
                             VDBS_OK);
            assert_memory_equal(got, values + (size_t)g * 3 * n + 3 * i, sizeof got);
        }
    }
    int far[3] = {100, 100, 100};
    float v3[3] = {1, 1, 1};
    assert_int_equal(vdbio_lit_vec3(lit, "radiance", far, v3, &err), VDBS_OK);
    assert_true(v3[0] == 0.0f && v3[1] == 0.0f && v3[2] == 0.0f);
    /* Wrong type and missing grid are errors, not crashes. */
    float f;
    assert_int_equal(vdbio_lit_float(lit, "radiance", far, &f, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "vec3s"));
    assert_int_equal(vdbio_lit_vec3(lit, "nope", far, v3, &err), VDBS_ERR_INPUT);

    /* Transforms carried bit for bit to every grid. */
    const vdbio_density_info *info = vdbio_density_get_info(d);
    const char *names[3] = {"density", "radiance", "ms"};
    for (int g = 0; g < 3; g++) {
        vdbio_transform t;
        assert_int_equal(vdbio_lit_transform(lit, names[g], &t, &err), VDBS_OK);
        assert_memory_equal(&t, &info->transform, sizeof t);
    }
    assert_string_equal(vdbio_lit_meta(lit, "vdbscatter_method"), "pop");
    assert_string_equal(vdbio_lit_meta(lit, "vdbscatter_scene"), "{\"a\": 1}");
    assert_string_equal(vdbio_lit_meta(lit, "creator"), "vdbscatter");
    assert_null(vdbio_lit_meta(lit, "missing"));
    /* file_compression etc. are not string metadata of ours; "file_bbox_min" is a vec3i. */
    vdbio_lit_close(lit);

    /* Grid classes, types and per-grid metadata as listed. */
    vdbio_grid_summary *list = NULL;
    int count = 0;
    assert_int_equal(vdbio_list_grids(path, &list, &count, &err), VDBS_OK);
    assert_int_equal(count, 3);
    assert_string_equal(list[0].name, "density");
    assert_string_equal(list[0].value_type, "float");
    assert_string_equal(list[0].grid_class, "fog volume");
    assert_int_equal(list[0].active_voxels, active);
    assert_string_equal(list[1].name, "radiance");
    assert_string_equal(list[1].value_type, "vec3s");
    assert_string_equal(list[1].grid_class, "unknown");
    assert_int_equal(list[1].active_voxels, n);
    assert_string_equal(list[2].name, "ms");
    assert_true(list[0].value_min == info->value_min);
    assert_true(list[0].value_max == info->value_max);
    free(list);

    /* Other readers: vdb_print and pyopenvdb (vec3 values, class, vector type, metadata). */
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "vdb_print -l -m '%s' > /dev/null", path);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd,
             "/usr/bin/python3 -c \""
             "import pyopenvdb as vdb, sys\n"
             "g = vdb.read('%s', 'radiance')\n"
             "assert g.gridClass == vdb.GridClass.UNKNOWN, g.gridClass\n"
             "assert g.vectorType == vdb.VectorType.INVARIANT, g.vectorType\n"
             "assert g['vdbscatter_method'] == 'pop'\n"
             "n = 0\n"
             "for it in g.citerOnValues():\n"
             "    x, y, z = it.min\n"
             "    assert it.count == 1\n"
             "    v = it.value\n"
             "    assert v == (x * 0.5, y * 0.25 - 3.0, z * 0.125), (it.min, v)\n"
             "    n += 1\n"
             "assert n == %zu, n\n"
             "m = vdb.readAllGridMetadata('%s')\n"
             "assert sorted(x.name for x in m) == ['density', 'ms', 'radiance'], m\n"
             "d = vdb.read('%s', 'density')\n"
             "assert d.activeVoxelCount() == %llu\n"
             "\"",
             path, n, path, path, (unsigned long long)active);
    assert_int_equal(system(cmd), 0);

    /* An existing output is replaced (rename over it). */
    free(coords);
    free(values);
    assert_int_equal(write_lit(path, d, 0, &w, &coords, &n, &values, &err), VDBS_OK);
    free(coords);
    free(values);
    vdbio_density_free(d);
}

static void test_half_clamp(void **state)
{
    (void)state;
    float v[8] = {1e6f, 2.0f, 3.5f, 65504.0f, 0.5f, 1.0f, 0.25f, 70000.0f};
    const int dims[3] = {2, 2, 2};
    vdbio_density *d = NULL;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_from_dense(v, dims, NULL, NULL, NULL, &d, &err), VDBS_OK);
    const char *path = test_tmp_path("vdbio_half.vdb");
    warnings w = {0};
    int32_t *coords;
    size_t n;
    float *values;
    /* Two density voxels (1e6, 70000) beyond half range; vec3 values are small. */
    assert_int_equal(write_lit(path, d, 1, &w, &coords, &n, &values, &err), VDBS_OK);
    assert_int_equal(w.count, 1);
    assert_non_null(strstr(w.last, "2 values"));
    assert_non_null(strstr(w.last, "65504"));
    vdbio_lit *lit = NULL;
    assert_int_equal(vdbio_lit_open(path, &lit, &err), VDBS_OK);
    int ijk0[3] = {0, 0, 0}, ijk1[3] = {1, 0, 0}, ijk2[3] = {1, 1, 0}, ijk7[3] = {1, 1, 1};
    float f;
    assert_int_equal(vdbio_lit_float(lit, "density", ijk0, &f, &err), VDBS_OK);
    assert_true(f == 65504.0f);
    assert_int_equal(vdbio_lit_float(lit, "density", ijk1, &f, &err), VDBS_OK);
    assert_true(f == 2.0f);
    assert_int_equal(vdbio_lit_float(lit, "density", ijk2, &f, &err), VDBS_OK);
    assert_true(f == 65504.0f);
    assert_int_equal(vdbio_lit_float(lit, "density", ijk7, &f, &err), VDBS_OK);
    assert_true(f == 65504.0f);
    /* The in-memory density is untouched. */
    assert_true(vdbio_density_value(d, ijk0) == 1e6f);
    /* Half storage rounds vec3 values: the dyadic test values are exact in half. */
    for (size_t i = 0; i < n; i++) {
        float got[3];
        assert_int_equal(vdbio_lit_vec3(lit, "radiance", coords + 3 * i, got, &err), VDBS_OK);
        assert_memory_equal(got, values + 3 * i, sizeof got);
    }
    vdbio_lit_close(lit);
    free(coords);
    free(values);

    /* vec3 values beyond range are counted with the density's in one warning. */
    int32_t c[6] = {0, 0, 0, 3, 3, 3};
    float big[6] = {-1e7f, 1.0f, 7e4f, 0.5f, 0.5f, 0.5f};
    vdbio_vec3_grid g = {"radiance", big};
    vdbio_write_request req;
    memset(&req, 0, sizeof req);
    req.density = d;
    req.coords = c;
    req.coord_count = 2;
    req.vec3_grids = &g;
    req.vec3_grid_count = 1;
    req.half = 1;
    req.warn = collect_warning;
    req.warn_user = &w;
    w.count = 0;
    assert_int_equal(vdbio_write(path, NULL, &req, &err), VDBS_OK);
    assert_int_equal(w.count, 1);
    assert_non_null(strstr(w.last, "4 values"));
    assert_int_equal(vdbio_lit_open(path, &lit, &err), VDBS_OK);
    float got[3];
    assert_int_equal(vdbio_lit_vec3(lit, "radiance", c, got, &err), VDBS_OK);
    assert_true(got[0] == -65504.0f && got[1] == 1.0f && got[2] == 65504.0f);
    assert_string_equal(vdbio_lit_meta(lit, "creator"), "vdbscatter");
    vdbio_lit_close(lit);
    vdbio_density_free(d);
}

static void test_write_refusals(void **state)
{
    (void)state;
    uint64_t active;
    vdbio_density *d = make_dense(&active);
    const char *in = test_tmp_path("vdbio_input.vdb");
    const char *link = test_tmp_path("vdbio_input_link.vdb");
    vdbs_error err = {{0}};
    const float v[1] = {1.0f};
    const int dims[3] = {1, 1, 1};
    assert_int_equal(vdbio_debug_write_float_grid(in, "density", v, dims, NULL, 0.0f, 0, &err),
                     VDBS_OK);
    long size = file_size(in);
    unlink(link);
    assert_int_equal(symlink(in, link), 0);
    vdbio_write_request req;
    memset(&req, 0, sizeof req);
    req.density = d;
    /* Same path, a symlink to it, and a path with "." in it: all refused, input intact. */
    assert_int_equal(vdbio_write(in, in, &req, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "input"));
    assert_int_equal(vdbio_write(link, in, &req, &err), VDBS_ERR_INPUT);
    char dotted[4096];
    snprintf(dotted, sizeof dotted, "%s/./vdbio_input.vdb", test_tmp_path(""));
    assert_int_equal(vdbio_write(dotted, in, &req, &err), VDBS_ERR_INPUT);
    assert_int_equal(file_size(in), size);
    /* A missing input never matches. */
    const char *out = test_tmp_path("vdbio_other.vdb");
    assert_int_equal(vdbio_write(out, test_tmp_path("does_not_exist.vdb"), &req, &err), VDBS_OK);
    assert_true(file_exists(out));
    /* A destination folder that does not exist is the user's error, found before writing;
     * so is a directory as the output path. No temp file is left. */
    assert_int_equal(vdbio_write(test_tmp_path("no/such/dir/x.vdb"), NULL, &req, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "x.vdb"));
    assert_non_null(strstr(err.message, "does not exist"));
    assert_int_equal(vdbio_write(test_tmp_path(""), NULL, &req, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "directory"));
    /* Bad requests. */
    vdbio_vec3_grid dup = {"density", v};
    int32_t c[3] = {0, 0, 0};
    req.coords = c;
    req.coord_count = 1;
    req.vec3_grids = &dup;
    req.vec3_grid_count = 1;
    assert_int_equal(vdbio_write(out, NULL, &req, &err), VDBS_ERR_INTERNAL);
    assert_int_equal(temp_files_left(), 0);
    unlink(link);
    vdbio_density_free(d);
}

static void test_real_files(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    struct {
        const char *file;
        uint64_t active, tiles;
        int bmin[3], bmax[3];
    } cases[] = {
        {"wdas_cloud_sixteenth.vdb", 415642, 130, {-66, -21, -90}, {59, 64, 63}},
        {"openvdb_smoke1.vdb", 1049275, 0, {1, 2, 1}, {111, 223, 112}},
        {"usd_smoke_000002.vdb", 71983, 0, {1, 1, 11}, {51, 49, 90}},
        {"usd_densityAndHeat.vdb", 6124, 0, {1, 1, 31}, {23, 23, 72}},
        {"smoke_double_128x64x64.vdb", 524288, 0, {0, 0, 0}, {127, 63, 63}},
        {"plasma_blender_fluid_0001_multigrid.vdb", 1016, 0, {5, 5, 5}, {18, 18, 19}},
        {"vpt_dragon_with_xform.vdb", 156161, 20, {-70, 1, -31}, {70, 99, 31}},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        w.count = 0;
        vdbio_density *d = read_ok(cases[c].file, &o);
        const vdbio_density_info *info = vdbio_density_get_info(d);
        assert_int_equal(w.count, 0);
        assert_string_equal(info->name, "density");
        assert_int_equal(info->active_voxels, cases[c].active);
        assert_int_equal(info->active_tiles, cases[c].tiles);
        for (int a = 0; a < 3; a++) {
            assert_int_equal(info->bbox_min[a], cases[c].bmin[a]);
            assert_int_equal(info->bbox_max[a], cases[c].bmax[a]);
        }
        assert_true(info->value_min >= 0.0f && info->value_max >= info->value_min);
        assert_true(info->original_background == 0.0);
        vdbio_density_free(d);
    }

    /* Double converted to float. */
    vdbio_density *d = read_ok("smoke_double_128x64x64.vdb", &o);
    assert_string_equal(vdbio_density_get_info(d)->source_type, "double");
    assert_true(vdbio_density_get_info(d)->value_max == 1.0f);
    vdbio_density_free(d);

    /* Second grid of a two-grid file by name. */
    o.grid_name = "heat";
    d = read_ok("usd_densityAndHeat.vdb", &o);
    assert_int_equal(vdbio_density_get_info(d)->active_voxels, 5224);
    assert_string_equal(vdbio_density_get_info(d)->name, "heat");
    vdbio_density_free(d);
    o.grid_name = NULL;

    /* Wrong grid names and types list what is there. */
    o.grid_name = "nope";
    read_fails(test_data_path("usd_densityAndHeat.vdb"), &o, "density (float), heat (float)");
    o.grid_name = "velocity";
    read_fails(test_data_path("usd_smoke_000001.vdb"), &o, "vec3s");
    o.grid_name = "obstacles";
    read_fails(test_data_path("usd_smoke_000001.vdb"), &o, "int32");
    o.grid_name = NULL;
    read_fails(test_data_path("usd_smoke_000001.vdb"), &o, "empty");
    o.grid_name = "flame";
    read_fails(test_data_path("plasma_blender_fluid_0001_multigrid.vdb"), &o, "empty");
    o.grid_name = NULL;
}

static void test_duplicate_names(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    const uint64_t expect[3] = {491, 2222, 803};
    for (int i = 0; i < 3; i++) {
        w.count = 0;
        o.grid_index = i;
        vdbio_density *d = read_ok("arnold_3density_grids.vdb", &o);
        assert_int_equal(vdbio_density_get_info(d)->active_voxels, expect[i]);
        if (i == 0) {
            assert_int_equal(w.count, 1);
            assert_non_null(strstr(w.last, "3 grids"));
            assert_non_null(strstr(w.last, "density@1"));
            assert_non_null(strstr(w.last, "arnold_3density_grids.vdb"));
        } else {
            assert_int_equal(w.count, 0);
            char want[32];
            snprintf(want, sizeof want, "density@%d", i);
            assert_string_equal(vdbio_density_get_info(d)->name, want);
        }
        vdbio_density_free(d);
    }
    o.grid_index = 3;
    read_fails(test_data_path("arnold_3density_grids.vdb"), &o, "out of range");
    o.grid_index = 1;
    read_fails(test_data_path("usd_smoke_000002.vdb"), &o, "out of range");
}

static void test_background_and_tiles(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    vdbio_density *d = read_ok("vpt_box.vdb", &o);
    const vdbio_density_info *info = vdbio_density_get_info(d);
    assert_int_equal(w.count, 1);
    assert_non_null(strstr(w.last, "background 1"));
    assert_non_null(strstr(w.last, "vpt_box.vdb"));
    assert_int_equal(info->active_voxels, 9261);
    assert_int_equal(info->active_tiles, 8);
    assert_true(info->original_background == 1.0);
    assert_true(info->value_min == 1.0f && info->value_max == 1.0f);
    int inside[3] = {0, 0, 0}, corner[3] = {10, -10, 10}, outside[3] = {11, 0, 0};
    int far[3] = {500, -300, 20}, near[3] = {-11, -11, -11};
    assert_true(vdbio_density_value(d, inside) == 1.0f);
    assert_true(vdbio_density_value(d, corner) == 1.0f);
    assert_true(vdbio_density_value(d, outside) == 0.0f);
    assert_true(vdbio_density_value(d, far) == 0.0f);
    assert_true(vdbio_density_value(d, near) == 0.0f);
    /* Inactive voxels inside the allocated leaves and tiles read 0 everywhere. */
    for (int k = -24; k < 24; k++)
        for (int j = -24; j < 24; j++)
            for (int i = -24; i < 24; i++) {
                int ijk[3] = {i, j, k};
                int in = abs(i) <= 10 && abs(j) <= 10 && abs(k) <= 10;
                assert_true(vdbio_density_value(d, ijk) == (in ? 1.0f : 0.0f));
            }
    /* Tiles voxelised for the output region. */
    assert_int_equal(coord_count(d, 0), 9261);
    assert_int_equal(coord_count(d, 1), 23 * 23 * 23);
    vdbio_density_free(d);
}

static void test_level_set(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    read_fails(test_data_path("openvdb_sphere_ls.vdb"), &o, "--from-levelset");
    read_fails(test_data_path("openvdb_sphere_ls.vdb"), &o, "level set");
    o.grid_name = "ls_sphere";
    read_fails(test_data_path("openvdb_sphere_ls.vdb"), &o, "level set");
    o.from_levelset = 1;
    o.grid_name = NULL; /* the only float grid, whatever its name */
    vdbio_density *d = read_ok("openvdb_sphere_ls.vdb", &o);
    const vdbio_density_info *info = vdbio_density_get_info(d);
    assert_string_equal(info->name, "ls_sphere");
    assert_true(info->active_voxels > 100000);
    assert_true(info->value_min >= 0.0f && info->value_max == 1.0f);
    int centre[3] = {0, 0, 0}, out[3] = {70, 0, 0};
    assert_true(vdbio_density_value(d, centre) == 1.0f);
    assert_true(vdbio_density_value(d, out) == 0.0f);
    assert_true(fabs(info->original_background - 0.150024) < 1e-6);
    vdbio_density_free(d);
    /* A fog volume with the flag: read unchanged, with a warning. */
    d = read_ok("usd_smoke_000002.vdb", &o);
    assert_int_equal(vdbio_density_get_info(d)->active_voxels, 71983);
    assert_int_equal(w.count, 1);
    vdbio_density_free(d);
}

static void test_rotated_transform(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    vdbio_density *d = read_ok("vpt_dragon_with_xform.vdb", &o);
    const vdbio_transform *t = &vdbio_density_get_info(d)->transform;
    /* vdb_print's rows are the images of the index axes: our columns. */
    const double expect[3][4] = {{0.0795, -0.0548, 0.0712, -0.2},
                                 {0.0742, 0.0937, -0.0107, 0.2},
                                 {-0.0507, 0.0511, 0.096, -0.2}};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            assert_true(fabs(t->m[r][c] - expect[r][c]) < 6e-5);
    const double *vs = vdbio_density_get_info(d)->voxel_size;
    for (int a = 0; a < 3; a++)
        assert_true(vs[a] > 0.1 && vs[a] < 0.14);

    /* Written and read back unchanged, on every grid. */
    const char *path = test_tmp_path("vdbio_dragon_lit.vdb");
    warnings ww = {0};
    int32_t *coords;
    size_t n;
    float *values;
    vdbs_error err = {{0}};
    assert_int_equal(write_lit(path, d, 0, &ww, &coords, &n, &values, &err), VDBS_OK);
    vdbio_lit *lit = NULL;
    assert_int_equal(vdbio_lit_open(path, &lit, &err), VDBS_OK);
    vdbio_transform back;
    assert_int_equal(vdbio_lit_transform(lit, "density", &back, &err), VDBS_OK);
    assert_memory_equal(&back, t, sizeof back);
    assert_int_equal(vdbio_lit_transform(lit, "ms", &back, &err), VDBS_OK);
    assert_memory_equal(&back, t, sizeof back);
    /* Every active density voxel and tile voxel is in the output region. */
    assert_true(n > vdbio_density_get_info(d)->active_voxels);
    for (size_t i = 0; i < n; i += 7) {
        float f;
        assert_int_equal(vdbio_lit_float(lit, "density", coords + 3 * i, &f, &err), VDBS_OK);
        float want = vdbio_density_value(d, coords + 3 * i);
        assert_memory_equal(&f, &want, sizeof f);
    }
    vdbio_lit_close(lit);
    /* Compared with the input file itself. */
    vdbio_grid_summary *list = NULL;
    int count = 0;
    assert_int_equal(
        vdbio_list_grids(test_data_path("vpt_dragon_with_xform.vdb"), &list, &count, &err),
        VDBS_OK);
    assert_int_equal(count, 1);
    assert_memory_equal(&list[0].transform, t, sizeof *t);
    free(list);
    free(coords);
    free(values);
    vdbio_density_free(d);
}

static void check_nanovdb(vdbio_density *d, int margin, int stride)
{
    void *buf = NULL;
    size_t size = 0;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_density_to_nanovdb(d, &buf, &size, &err), VDBS_OK);
    assert_non_null(buf);
    assert_int_equal((uintptr_t)buf % 32, 0);
    assert_int_equal(size % 32, 0);
    pnanovdb_buf_t pbuf = pnanovdb_make_buf((uint32_t *)buf, size / 4);
    pnanovdb_grid_handle_t grid = {pnanovdb_address_null()};
    assert_int_equal(pnanovdb_grid_get_grid_type(pbuf, grid), PNANOVDB_GRID_TYPE_FLOAT);
    pnanovdb_tree_handle_t tree = pnanovdb_grid_get_tree(pbuf, grid);
    pnanovdb_root_handle_t root = pnanovdb_tree_get_root(pbuf, tree);
    pnanovdb_readaccessor_t acc;
    pnanovdb_readaccessor_init(&acc, root);
    const vdbio_density_info *info = vdbio_density_get_info(d);
    uint64_t checked = 0, nonzero = 0;
    for (int k = info->bbox_min[2] - margin; k <= info->bbox_max[2] + margin; k += stride)
        for (int j = info->bbox_min[1] - margin; j <= info->bbox_max[1] + margin; j++)
            for (int i = info->bbox_min[0] - margin; i <= info->bbox_max[0] + margin; i++) {
                pnanovdb_coord_t ijk = {i, j, k};
                pnanovdb_address_t a = pnanovdb_readaccessor_get_value_address(
                    PNANOVDB_GRID_TYPE_FLOAT, pbuf, &acc, &ijk);
                float nano = pnanovdb_read_float(pbuf, a);
                int c[3] = {i, j, k};
                float want = vdbio_density_value(d, c);
                if (memcmp(&nano, &want, sizeof nano) != 0)
                    fail_msg("(%d,%d,%d): nanovdb %g, openvdb %g", i, j, k, nano, want);
                checked++;
                nonzero += want != 0.0f;
            }
    assert_true(checked > 1000);
    assert_true(nonzero > 0);
    /* The world transform matches too (single precision in NanoVDB). */
    pnanovdb_vec3_t p = {3.0f, -2.0f, 5.0f};
    pnanovdb_vec3_t wpos = pnanovdb_grid_index_to_worldf(pbuf, grid, &p);
    const double *m[3] = {info->transform.m[0], info->transform.m[1], info->transform.m[2]};
    double wx = m[0][0] * 3 - m[0][1] * 2 + m[0][2] * 5 + m[0][3];
    double wy = m[1][0] * 3 - m[1][1] * 2 + m[1][2] * 5 + m[1][3];
    double wz = m[2][0] * 3 - m[2][1] * 2 + m[2][2] * 5 + m[2][3];
    assert_true(fabs(wpos.x - wx) < 1e-4 * (1 + fabs(wx)));
    assert_true(fabs(wpos.y - wy) < 1e-4 * (1 + fabs(wy)));
    assert_true(fabs(wpos.z - wz) < 1e-4 * (1 + fabs(wz)));
    free(buf);
}

static void test_nanovdb(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    vdbio_density *d = read_ok("wdas_cloud_sixteenth.vdb", &o);
    check_nanovdb(d, 2, 1);
    vdbio_density_free(d);
    d = read_ok("vpt_box.vdb", &o);
    check_nanovdb(d, 20, 1);
    vdbio_density_free(d);
    d = read_ok("vpt_dragon_with_xform.vdb", &o);
    check_nanovdb(d, 3, 3);
    vdbio_density_free(d);
    uint64_t active;
    d = make_dense(&active);
    check_nanovdb(d, 2, 1);
    vdbio_density_free(d);
}

static void test_bad_files(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    read_fails(test_tmp_path("no_such_file.vdb"), &o, "no such file");
    const char *text = test_tmp_path("vdbio_text.vdb");
    FILE *f = fopen(text, "w");
    assert_non_null(f);
    fputs("This is not a volume.\nJust text.\n", f);
    fclose(f);
    read_fails(text, &o, "not an OpenVDB file");
    const char *empty = test_tmp_path("vdbio_empty.vdb");
    f = fopen(empty, "w");
    assert_non_null(f);
    fclose(f);
    read_fails(empty, &o, "not an OpenVDB file");
    read_fails(test_tmp_path(""), &o, "directory");

    /* Truncated copies of real files, cut anywhere: a clear error, never a crash or
     * silently wrong data. */
    const char *files[] = {"wdas_cloud_sixteenth.vdb",   "arnold_3density_grids.vdb",
                           "smoke_double_128x64x64.vdb", "vpt_dragon_with_xform.vdb",
                           "usd_smoke_000001.vdb",       "plasma_blender_fluid_0001_multigrid.vdb",
                           "openvdb_smoke1.vdb"};
    const double cuts[] = {0.5, 0.01, 0.1, 0.3, 0.9, 0.99};
    const char *cut = test_tmp_path("vdbio_truncated.vdb");
    int n_cases = 0;
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        long size = file_size(test_data_path(files[i]));
        long lengths[8];
        int nl = 0;
        for (size_t c = 0; c < sizeof cuts / sizeof cuts[0]; c++)
            lengths[nl++] = (long)(size * cuts[c]);
        lengths[nl++] = size - 1;
        lengths[nl++] = 20;
        for (int l = 0; l < nl; l++) {
            copy_prefix(test_data_path(files[i]), cut, lengths[l]);
            vdbio_density *d = NULL;
            vdbs_error err = {{0}};
            vdbs_status st = vdbio_density_read(cut, &o, &d, &err);
            if (st != VDBS_ERR_INPUT || d)
                fail_msg("%s cut to %ld bytes: status %d '%s'", files[i], lengths[l], st,
                         err.message);
            if (!strstr(err.message, "truncated") && !strstr(err.message, "corrupt"))
                fail_msg("%s cut to %ld: '%s'", files[i], lengths[l], err.message);
            assert_non_null(strstr(err.message, "vdbio_truncated.vdb"));
            assert_null(strchr(err.message, '\n'));
            vdbio_grid_summary *list = NULL;
            int count = 0;
            assert_int_equal(vdbio_list_grids(cut, &list, &count, &err), VDBS_ERR_INPUT);
            assert_null(list);
            vdbio_lit *lit = NULL;
            assert_int_equal(vdbio_lit_open(cut, &lit, &err), VDBS_ERR_INPUT);
            assert_null(lit);
            n_cases++;
        }
    }
    assert_int_equal(n_cases, 7 * 8);
    /* The file cut to half its size must be reported as "truncated". */
    copy_prefix(test_data_path("wdas_cloud_sixteenth.vdb"), cut,
                file_size(test_data_path("wdas_cloud_sixteenth.vdb")) / 2);
    read_fails(cut, &o, "truncated");
    vdbio_grid_summary *list = NULL;
    int count = 0;
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_list_grids(text, &list, &count, &err), VDBS_ERR_INPUT);
}

/* The value length of a string metadata entry `key` (file or grid metadata) set to 2 GB, as
 * a fuzzed file had it: refused before OpenVDB allocates and fills the string. */
static void corrupt_meta_length(const char *from, const char *to, const char *key)
{
    long size = file_size(from);
    char *bytes = malloc((size_t)size);
    assert_non_null(bytes);
    FILE *f = fopen(from, "rb");
    assert_non_null(f);
    assert_int_equal(fread(bytes, 1, (size_t)size, f), (size_t)size);
    fclose(f);
    char entry[64];
    const uint32_t key_len = (uint32_t)strlen(key), type_len = 6;
    memcpy(entry, &key_len, 4);
    memcpy(entry + 4, key, key_len);
    memcpy(entry + 4 + key_len, &type_len, 4);
    memcpy(entry + 8 + key_len, "string", 6);
    char *at = NULL;
    for (long i = 0; !at && i + 18 + (long)key_len <= size; i++)
        if (memcmp(bytes + i, entry, 14 + key_len) == 0)
            at = bytes + i;
    assert_non_null(at);
    const uint32_t absurd = 0x74617000u;
    memcpy(at + 14 + key_len, &absurd, 4);
    f = fopen(to, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, (size_t)size, f), (size_t)size);
    fclose(f);
    free(bytes);
}

/* The dense test grid's lit VDB written to the temporary folder as `file` (its coordinates and
 * values as write_lit gives them); returns its path. */
static const char *dense_lit(const char *file, int32_t **coords, size_t *n, float **values)
{
    uint64_t active;
    vdbio_density *d = make_dense(&active);
    const char *path = test_tmp_path(file);
    warnings w = {0};
    vdbs_error err = {{0}};
    assert_int_equal(write_lit(path, d, 0, &w, coords, n, values, &err), VDBS_OK);
    vdbio_density_free(d);
    return path;
}

static void test_metadata_lengths(void **state)
{
    (void)state;
    int32_t *coords;
    size_t n;
    float *values;
    const char *path = dense_lit("vdbio_meta.vdb", &coords, &n, &values);
    free(coords);
    free(values);
    warnings w = {0};
    vdbs_error err = {{0}};
    const char *bad = test_tmp_path("vdbio_meta_length.vdb");
    const struct {
        const char *key, *expect;
    } cases[] = {{"vdbscatter_method", "file metadata"}, {"class", "grid metadata"}};
    vdbio_read_options o = options(&w);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        corrupt_meta_length(path, bad, cases[c].key);
        read_fails(bad, &o, cases[c].expect);
        vdbio_grid_summary *list = NULL;
        int count = 0;
        assert_int_equal(vdbio_list_grids(bad, &list, &count, &err), VDBS_ERR_INPUT);
        assert_non_null(strstr(err.message, cases[c].expect));
        vdbio_lit *lit = NULL;
        assert_int_equal(vdbio_lit_open(bad, &lit, &err), VDBS_ERR_INPUT);
        assert_non_null(strstr(err.message, cases[c].expect));
    }
}

static void test_bad_values(void **state)
{
    (void)state;
    warnings w = {0};
    vdbio_read_options o = options(&w);
    float v[4 * 4 * 4];
    for (int i = 0; i < 64; i++)
        v[i] = 0.5f;
    /* Element (i,j,k) = (1,2,3) with origin (10,20,30) is index (11,22,33). */
    v[(3 * 4 + 2) * 4 + 1] = NAN;
    v[(0 * 4 + 0) * 4 + 3] = INFINITY;
    v[(1 * 4 + 1) * 4 + 1] = -0.25f;
    v[(1 * 4 + 1) * 4 + 2] = -2.0f;
    v[(2 * 4 + 1) * 4 + 2] = -1.0f;
    const int dims[3] = {4, 4, 4}, origin[3] = {10, 20, 30};
    const char *path = test_tmp_path("vdbio_bad_values.vdb");
    vdbs_error err = {{0}};
    assert_int_equal(vdbio_debug_write_float_grid(path, "density", v, dims, origin, 0.0f, 0, &err),
                     VDBS_OK);
    read_fails(path, &o, "2 NaN/Inf active values");
    read_fails(path, &o, "3 negative active values");
    read_fails(path, &o, "index (13, 20, 30)"); /* the Inf comes first in tree order */
    read_fails(path, &o, "world (13, 20, 30)");
    read_fails(path, &o, "index (11, 21, 31)");

    /* Only negatives, in a fog volume. */
    for (int i = 0; i < 64; i++)
        v[i] = i == 5 ? -1.0f : 0.5f;
    assert_int_equal(vdbio_debug_write_float_grid(path, "density", v, dims, NULL, 0.0f, 0, &err),
                     VDBS_OK);
    read_fails(path, &o, "1 negative active value (first -1 at index (1, 1, 0)");

    /* A level-set-class grid written by us, refused and then converted. */
    for (int i = 0; i < 64; i++)
        v[i] = (float)(i % 4) - 1.5f;
    assert_int_equal(
        vdbio_debug_write_float_grid(path, "sdf", v, dims, NULL, 3.0f, VDBIO_DEBUG_LEVEL_SET, &err),
        VDBS_OK);
    read_fails(path, &o, "--from-levelset");

    /* Frustum transforms are refused. */
    for (int i = 0; i < 64; i++)
        v[i] = 0.5f;
    assert_int_equal(vdbio_debug_write_float_grid(path, "density", v, dims, NULL, 0.0f,
                                                  VDBIO_DEBUG_FRUSTUM, &err),
                     VDBS_OK);
    read_fails(path, &o, "non-linear");
    vdbio_grid_summary *list = NULL;
    int count = 0;
    assert_int_equal(vdbio_list_grids(path, &list, &count, &err), VDBS_OK);
    assert_int_equal(count, 1);
    assert_int_equal(list[0].is_affine, 0);
    free(list);

    /* Double with a non-zero background: converted, background reset with a warning. */
    assert_int_equal(
        vdbio_debug_write_float_grid(path, "dens", v, dims, NULL, 0.25f, VDBIO_DEBUG_DOUBLE, &err),
        VDBS_OK);
    w.count = 0;
    vdbio_density *d = NULL;
    assert_int_equal(vdbio_density_read(path, &o, &d, &err), VDBS_OK);
    assert_string_equal(vdbio_density_get_info(d)->source_type, "double");
    assert_string_equal(vdbio_density_get_info(d)->name, "dens");
    assert_int_equal(vdbio_density_get_info(d)->active_voxels, 64);
    assert_int_equal(w.count, 1);
    assert_non_null(strstr(w.last, "background 0.25"));
    int outside[3] = {9, 9, 9};
    assert_true(vdbio_density_value(d, outside) == 0.0f);
    vdbio_density_free(d);

    /* A file without grids. */
    assert_int_equal(vdbio_debug_write_float_grid(path, NULL, NULL, NULL, NULL, 0.0f, 0, &err),
                     VDBS_OK);
    read_fails(path, &o, "no grids");
    assert_int_equal(vdbio_list_grids(path, &list, &count, &err), VDBS_OK);
    assert_int_equal(count, 0);
    free(list);
}

static void test_list_grids(void **state)
{
    (void)state;
    vdbio_grid_summary *g = NULL;
    int n = 0;
    vdbs_error err = {{0}};
    assert_int_equal(
        vdbio_list_grids(test_data_path("plasma_blender_fluid_0001_multigrid.vdb"), &g, &n, &err),
        VDBS_OK);
    assert_int_equal(n, 8);
    /* File order, not alphabetical. */
    const char *order[8] = {"velocity", "density", "shadow",  "temperature",
                            "flame",    "color_r", "color_g", "color_b"};
    for (int i = 0; i < 8; i++)
        assert_string_equal(g[i].name, order[i]);
    assert_string_equal(g[0].value_type, "vec3s");
    assert_string_equal(g[0].grid_class, "staggered");
    assert_int_equal(g[0].active_voxels, 1016);
    assert_true(g[0].value_min == 0.0 && g[0].value_max == 0.0);
    assert_string_equal(g[1].value_type, "float");
    assert_string_equal(g[1].grid_class, "fog volume");
    assert_int_equal(g[1].active_voxels, 1016);
    assert_true(g[1].value_max > g[1].value_min && g[1].value_min >= 0.0);
    assert_int_equal(g[1].bbox_min[0], 5);
    assert_int_equal(g[1].bbox_max[2], 19);
    assert_int_equal(g[1].is_affine, 1);
    assert_true(fabs(g[1].voxel_size[0] - 0.1666667) < 1e-5);
    assert_int_equal(g[4].active_voxels, 0);
    assert_int_equal(g[4].bbox_min[0], 0);
    assert_int_equal(g[4].bbox_max[0], -1);
    free(g);

    assert_int_equal(vdbio_list_grids(test_data_path("usd_smoke_000001.vdb"), &g, &n, &err),
                     VDBS_OK);
    assert_int_equal(n, 4);
    int types = 0;
    for (int i = 0; i < n; i++) {
        types |= !strcmp(g[i].value_type, "int32") ? 1 : 0;
        types |= !strcmp(g[i].value_type, "vec3s") ? 2 : 0;
        types |= !strcmp(g[i].value_type, "float") ? 4 : 0;
        assert_int_equal(g[i].active_voxels, 0);
    }
    assert_int_equal(types, 7);
    free(g);

    assert_int_equal(vdbio_list_grids(test_data_path("smoke_double_128x64x64.vdb"), &g, &n, &err),
                     VDBS_OK);
    assert_int_equal(n, 1);
    assert_string_equal(g[0].value_type, "double");
    assert_int_equal(g[0].active_voxels, 524288);
    assert_true(g[0].value_min == 0.0 && g[0].value_max == 1.0);
    assert_true(g[0].transform.m[0][3] == -64.0 && g[0].transform.m[1][3] == -32.0);
    free(g);

    assert_int_equal(vdbio_list_grids(test_data_path("vpt_box.vdb"), &g, &n, &err), VDBS_OK);
    assert_true(g[0].background == 1.0);
    assert_int_equal(g[0].active_tiles, 8);
    assert_int_equal(g[0].active_voxels, 9261);
    assert_true(g[0].value_min == 1.0 && g[0].value_max == 1.0);
    assert_true(fabs(g[0].voxel_size[1] - 0.05) < 1e-9);
    free(g);

    assert_int_equal(vdbio_list_grids(test_data_path("arnold_3density_grids.vdb"), &g, &n, &err),
                     VDBS_OK);
    assert_int_equal(n, 3);
    assert_int_equal(g[0].active_voxels, 491);
    assert_int_equal(g[1].active_voxels, 2222);
    assert_int_equal(g[2].active_voxels, 803);
    free(g);

    assert_int_equal(vdbio_list_grids(test_tmp_path("missing.vdb"), &g, &n, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "missing.vdb"));
}

static void test_lit_threads(void **state)
{
    (void)state;
    int32_t *coords;
    size_t n;
    float *values;
    const char *path = dense_lit("vdbio_threads.vdb", &coords, &n, &values);
    vdbs_error err = {{0}};
    vdbio_lit *lit = NULL;
    assert_int_equal(vdbio_lit_open(path, &lit, &err), VDBS_OK);
    long bad = 0;
#pragma omp parallel for reduction(+ : bad)
    for (long r = 0; r < 40 * (long)n; r++) {
        size_t i = (size_t)(r * 7919 % (long)n);
        int g = (int)(r & 1);
        float got[3];
        vdbs_error e;
        if (vdbio_lit_vec3(lit, g ? "ms" : "radiance", coords + 3 * i, got, &e) != VDBS_OK ||
            memcmp(got, values + (size_t)g * 3 * n + 3 * i, sizeof got) != 0)
            bad++;
    }
    assert_int_equal(bad, 0);
    vdbio_lit_close(lit);
    free(coords);
    free(values);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_from_dense_info),  cmocka_unit_test(test_output_coords),
        cmocka_unit_test(test_round_trip),       cmocka_unit_test(test_half_clamp),
        cmocka_unit_test(test_write_refusals),   cmocka_unit_test(test_real_files),
        cmocka_unit_test(test_duplicate_names),  cmocka_unit_test(test_background_and_tiles),
        cmocka_unit_test(test_level_set),        cmocka_unit_test(test_rotated_transform),
        cmocka_unit_test(test_nanovdb),          cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_metadata_lengths), cmocka_unit_test(test_bad_values),
        cmocka_unit_test(test_list_grids),       cmocka_unit_test(test_lit_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
