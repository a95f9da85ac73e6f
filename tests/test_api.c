/* The public API (vdbscatter.h) from C, in the suite's ASan pass too: commands run from their
 * words, what they say and where, cancelling, the kept picture against the file, dense copies
 * against the lit reader, the option tables. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testutil.h"
#include "vdbscatter/image.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/vdbscatter.h"

typedef struct heard {
    char text[5][8192]; /* per vdbs_message_kind, concatenated */
    int count[5];
} heard;

static void listen(void *user, vdbs_message_kind kind, const char *text)
{
    heard *h = user;
    assert_true(kind >= VDBS_MESSAGE_OUTPUT && kind <= VDBS_MESSAGE_PROGRESS);
    strncat(h->text[kind], text, sizeof h->text[kind] - strlen(h->text[kind]) - 1);
    ++h->count[kind];
}

/* Runs the words (NULL-terminated) with desc's other fields; returns the exit status. */
static int run(vdbs_command_desc *desc, vdbs_command_result *result, const char *const *words)
{
    int n = 0;
    while (words[n])
        ++n;
    desc->argc = n;
    desc->argv = words;
    return vdbs_command_run(desc, result);
}

/* Runs words that must succeed, with no callback. */
static void run_ok(const char *const *words)
{
    vdbs_command_desc desc = {0};
    vdbs_command_result r;
    assert_int_equal(run(&desc, &r, words), 0);
    vdbs_command_result_free(&r);
}

/* The tests' volume and its lit VDB, made once per program. */
static const char *cloud(void)
{
    static char path[4096]; /* test_tmp_path's buffers are reused */
    if (!path[0]) {
        snprintf(path, sizeof path, "%s", test_tmp_path("api_cloud.vdb"));
        const char *words[] = {"sample", "cloud", "-o", path, "--res", "24", "-q", NULL};
        run_ok(words);
    }
    return path;
}

static const char *lit(void)
{
    static char path[4096]; /* test_tmp_path's buffers are reused */
    if (!path[0]) {
        snprintf(path, sizeof path, "%s", test_tmp_path("api_lit.vdb"));
        const char *words[] = {"bake",  cloud(),       "-o",        path,  "--sun", "0.3,-1,0.2",
                               "--env", "0.2,0.3,0.5", "--backend", "cpu", "-q",    NULL};
        run_ok(words);
    }
    return path;
}

/* OUTPUT goes to the callback and into result.output alike; an error is one ERROR line,
 * the result's message and status; nothing else is said. */
static void test_messages_and_errors(void **state)
{
    (void)state;
    heard h = {0};
    vdbs_command_desc desc = {.message = listen, .message_user = &h};
    vdbs_command_result r;
    const char *info[] = {"info", cloud(), "--json", NULL};
    assert_int_equal(run(&desc, &r, info), 0);
    assert_int_equal(r.status, VDBS_OK);
    assert_true(strlen(r.output) > 20 && r.output[0] == '{');
    assert_string_equal(r.output, h.text[VDBS_MESSAGE_OUTPUT]);
    assert_int_equal(r.output_size, strlen(r.output));
    assert_int_equal(h.count[VDBS_MESSAGE_ERROR] + h.count[VDBS_MESSAGE_WARNING], 0);
    vdbs_command_result_free(&r);

    memset(&h, 0, sizeof h);
    const char *missing[] = {"bake", test_tmp_path("api_missing.vdb"), "-o",
                             test_tmp_path("api_x.vdb"), NULL};
    assert_int_equal(run(&desc, &r, missing), 2);
    assert_int_equal(r.status, VDBS_ERR_INPUT);
    assert_non_null(strstr(r.error, "api_missing.vdb"));
    assert_int_equal(h.count[VDBS_MESSAGE_ERROR], 1);
    char line[2048];
    snprintf(line, sizeof line, "vdbscatter bake: %s\n", r.error);
    assert_string_equal(h.text[VDBS_MESSAGE_ERROR], line);
    assert_string_equal(r.output, "");
    assert_int_equal(access(test_tmp_path("api_x.vdb"), F_OK), -1);
    vdbs_command_result_free(&r);

    const char *bad_value[] = {"bake",     cloud(), "-o", test_tmp_path("api_x.vdb"),
                               "--albedo", "x",     NULL};
    assert_int_equal(run(&desc, &r, bad_value), 2);
    assert_non_null(strstr(r.error, "--albedo"));
    vdbs_command_result_free(&r);

    const char *unknown[] = {"bakee", NULL};
    assert_int_equal(run(&desc, &r, unknown), 2);
    assert_int_equal(r.status, VDBS_ERR_INPUT);
    assert_non_null(strstr(r.error, "unknown command 'bakee'"));
    vdbs_command_result_free(&r);

    vdbs_command_desc empty = {0};
    assert_int_equal(vdbs_command_run(&empty, &r), 2);
    assert_string_equal(r.output, "");
    vdbs_command_result_free(&r);
}

/* A flag set before the bake starts: it stops at its first poll, exit 128 + the value, the
 * ERROR "interrupted", and no output file. */
static void test_cancel(void **state)
{
    (void)state;
    const char *out = test_tmp_path("api_cancelled.vdb");
    unlink(out);
    vdbs_cancel cancel = 2;
    vdbs_command_desc desc = {.cancel = &cancel};
    vdbs_command_result r;
    const char *words[] = {"bake", cloud(), "-o", out, "--sun", "0,-1,0", "--backend", "cpu", NULL};
    assert_int_equal(run(&desc, &r, words), 130);
    assert_int_equal(r.status, VDBS_ERR_CANCELLED);
    assert_string_equal(r.error, "interrupted");
    assert_int_equal(access(out, F_OK), -1);
    vdbs_command_result_free(&r);
}

/* keep_image: the picture without a file, and the same floats as the file with one. */
static void test_kept_picture(void **state)
{
    (void)state;
    const char *exr = test_tmp_path("api_render.exr");
    vdbs_command_desc desc = {.keep_image = 1};
    vdbs_command_result kept, filed;
    const char *bare[] = {"render", lit(), "--size", "40x30", "--backend", "cpu", "-q", NULL};
    assert_int_equal(run(&desc, &kept, bare), 0);
    assert_int_equal(kept.width, 40);
    assert_int_equal(kept.height, 30);
    assert_non_null(kept.rgb);
    assert_null(kept.se);
    const char *to_file[] = {"render", lit(), "--size", "40x30", "--backend",
                             "cpu",    "-o",  exr,      "-q",    NULL};
    assert_int_equal(run(&desc, &filed, to_file), 0);
    vdbs_image image = {0};
    vdbs_error err;
    assert_int_equal(vdbs_image_read(exr, &image, &err), VDBS_OK);
    size_t n = 3 * 40 * 30;
    assert_memory_equal(kept.rgb, image.rgb, n * sizeof(float));
    assert_memory_equal(filed.rgb, image.rgb, n * sizeof(float));
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i)
        sum += image.rgb[i];
    assert_true(sum > 0.0);
    vdbs_image_free(&image);
    vdbs_command_result_free(&kept);
    vdbs_command_result_free(&filed);

    /* Without keep_image, -o stays required. */
    vdbs_command_desc plain = {0};
    assert_int_equal(run(&plain, &kept, bare), 2);
    assert_non_null(strstr(kept.error, "missing -o"));
    vdbs_command_result_free(&kept);

    const char *reference[] = {"render", cloud(), "--mode", "reference", "--size", "8x6",
                               "--spp",  "4",     "--sun",  "0,-1,0",    "-q",     NULL};
    assert_int_equal(run(&desc, &kept, reference), 0);
    assert_non_null(kept.se);
    vdbs_command_result_free(&kept);
}

/* Dense copies hold the lit reader's values voxel by voxel, one grid or all at once, and the
 * memory limit holds all copies together. */
static void test_dense(void **state)
{
    (void)state;
    vdbio_lit *reader = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_lit_open(lit(), &reader, &err), VDBS_OK);
    vdbs_dense_grid *all = NULL;
    int count = 0;
    assert_int_equal(vdbs_dense_read_all(lit(), -1, &all, &count, &err), VDBS_OK);
    int64_t bytes = 0, checked = 0;
    int saw_radiance = 0, saw_density = 0;
    for (int i = 0; i < count; ++i) {
        const vdbs_dense_grid *g = &all[i];
        bytes += (int64_t)g->size[0] * g->size[1] * g->size[2] * g->channels * 4;
        saw_radiance |= strcmp(g->name, "radiance") == 0 && g->channels == 3;
        saw_density |= strcmp(g->name, "density") == 0 && g->channels == 1;
        vdbs_dense_grid one;
        assert_int_equal(vdbs_dense_read(lit(), g->name, -1, &one, &err), VDBS_OK);
        assert_memory_equal(one.size, g->size, sizeof one.size);
        assert_memory_equal(one.origin, g->origin, sizeof one.origin);
        const size_t n = (size_t)g->size[0] * g->size[1] * g->size[2] * g->channels;
        if (n)
            assert_memory_equal(one.values, g->values, n * sizeof(float));
        vdbs_dense_free(&one);
        /* Every voxel of the box against the reader's lookup (0 where inactive). */
        for (int z = 0; z < g->size[2]; ++z)
            for (int y = 0; y < g->size[1]; ++y)
                for (int x = 0; x < g->size[0]; ++x) {
                    const int ijk[3] = {g->origin[0] + x, g->origin[1] + y, g->origin[2] + z};
                    const float *v =
                        g->values + (((size_t)z * g->size[1] + y) * g->size[0] + x) * g->channels;
                    float want[3] = {0};
                    vdbs_status st = g->channels == 3
                                         ? vdbio_lit_vec3(reader, g->name, ijk, want, &err)
                                         : vdbio_lit_float(reader, g->name, ijk, want, &err);
                    assert_int_equal(st, VDBS_OK);
                    assert_memory_equal(v, want, (size_t)g->channels * sizeof(float));
                    ++checked;
                }
    }
    assert_true(saw_radiance && saw_density && checked > 1000);
    vdbio_lit_close(reader);
    vdbs_dense_free_all(all, count);

    assert_int_equal(vdbs_dense_read_all(lit(), bytes, &all, &count, &err), VDBS_OK);
    vdbs_dense_free_all(all, count);
    assert_int_equal(vdbs_dense_read_all(lit(), bytes - 1, &all, &count, &err), VDBS_ERR_INPUT);
    assert_null(all);
    assert_non_null(strstr(err.message, "max_memory"));

    vdbs_dense_grid g;
    assert_int_equal(vdbs_dense_read(lit(), "no_such_grid", 0, &g, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "no_such_grid"));
    assert_int_equal(vdbs_dense_read(test_tmp_path("api_missing.vdb"), NULL, 0, &g, &err),
                     VDBS_ERR_INPUT);
}

/* The option tables: every command is there, the light flags repeat, unknown is -1. */
static void test_option_tables(void **state)
{
    (void)state;
    int commands = 0;
    for (const char *const *c = vdbs_command_names(); *c; ++c, ++commands)
        assert_true(vdbs_command_option_count(*c) > 0);
    assert_int_equal(commands, 7);
    assert_int_equal(vdbs_command_option_count("nope"), -1);
    int found = 0;
    for (int i = 0; i < vdbs_command_option_count("bake"); ++i) {
        vdbs_arg_option o;
        assert_int_equal(vdbs_command_option_get("bake", i, &o), VDBS_OK);
        if (strcmp(o.name, "--sun") == 0 || strcmp(o.name, "--point") == 0 ||
            strcmp(o.name, "--env") == 0)
            found += o.kind == VDBS_ARG_LIST;
        if (strcmp(o.name, "--json") == 0)
            found += o.kind == VDBS_ARG_FLAG;
        if (strcmp(o.name, "--density-scale") == 0)
            found += o.kind == VDBS_ARG_VALUE;
    }
    assert_int_equal(found, 5);
    vdbs_arg_option o;
    assert_int_equal(vdbs_command_option_get("bake", vdbs_command_option_count("bake"), &o),
                     VDBS_ERR_INPUT);
    assert_non_null(vdbs_version());
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_messages_and_errors), cmocka_unit_test(test_cancel),
        cmocka_unit_test(test_kept_picture),        cmocka_unit_test(test_dense),
        cmocka_unit_test(test_option_tables),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
