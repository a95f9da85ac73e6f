/* The library's cancel flag (cancel.h): a set flag stops the kernel runner, and the writers
 * remove their temporary file and leave the old output as it was. The CLI's signals are
 * tested in test_interrupt_cli.py. */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/cancel.h"
#include "vdbscatter/image.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/vdbio.h"

static void count_items(void *user, uint64_t begin, uint64_t end)
{
    uint64_t *count = user;
#pragma omp atomic
    *count += end - begin;
}

/* Whether the test temp folder holds a temporary file of `name` (".NAME.tmp.PID"). */
static int temp_left(const char *name)
{
    char prefix[256];
    snprintf(prefix, sizeof prefix, ".%s.tmp.", name);
    DIR *dir = opendir(VDBS_TEST_TMP_DIR);
    assert_non_null(dir);
    int found = 0;
    for (struct dirent *e; (e = readdir(dir));)
        found = found || strncmp(e->d_name, prefix, strlen(prefix)) == 0;
    closedir(dir);
    return found;
}

static long file_bytes(const char *path, char *buf, long size)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    long n = (long)fread(buf, 1, (size_t)size, f);
    fclose(f);
    return n;
}

static void test_kernel_run_stops(void **state)
{
    (void)state;
    vdbs_runner_desc rd = {.backend = VDBS_BACKEND_CPU};
    vdbs_runner *runner = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_runner_create(&rd, &runner, &err), VDBS_OK);
    uint64_t count = 0;
    vdbs_cancel flag = 0;
    vdbs_kernel_desc desc = {0};
    desc.items = 100000;
    desc.cpu_chunk = 100;
    desc.user = &count;
    desc.cpu_items = count_items;
    desc.shader = "unused.comp";
    desc.cancel = &flag;
    assert_int_equal(vdbs_kernel_run(runner, &desc, NULL, &err), VDBS_OK);
    assert_int_equal(count, 100000);
    flag = 2;
    count = 0;
    assert_int_equal(vdbs_kernel_run(runner, &desc, NULL, &err), VDBS_ERR_CANCELLED);
    assert_string_equal(err.message, "interrupted");
    assert_int_equal(count, 0);
    /* The progress counter carries it too. */
    vdbs_progress progress = {0};
    progress.cancel = &flag;
    desc.cancel = NULL;
    desc.progress = &progress;
    assert_int_equal(vdbs_kernel_run(runner, &desc, NULL, &err), VDBS_ERR_CANCELLED);
    assert_int_equal(count, 0);
    vdbs_runner_destroy(runner);
}

static void test_image_write_keeps_old(void **state)
{
    (void)state;
    vdbs_image image;
    vdbs_error err;
    assert_int_equal(vdbs_image_alloc(&image, 8, 4, 0, &err), VDBS_OK);
    for (int i = 0; i < 8 * 4 * 3; ++i)
        image.rgb[i] = 0.5f;
    const char *path = test_tmp_path("cancel_old.png");
    assert_int_equal(vdbs_image_write(path, &image, 0.0, &err), VDBS_OK);
    static char before[1 << 16], after[1 << 16];
    long n = file_bytes(path, before, sizeof before);
    vdbs_cancel flag = 15;
    for (int i = 0; i < 8 * 4 * 3; ++i)
        image.rgb[i] = 1.0f;
    assert_int_equal(vdbs_image_write_cancel(path, &image, 0.0, &flag, &err), VDBS_ERR_CANCELLED);
    assert_int_equal(file_bytes(path, after, sizeof after), n);
    assert_memory_equal(before, after, (size_t)n);
    assert_false(temp_left("cancel_old.png"));
    flag = 0;
    assert_int_equal(vdbs_image_write_cancel(path, &image, 0.0, &flag, &err), VDBS_OK);
    assert_false(temp_left("cancel_old.png"));
    vdbs_image_free(&image);
    remove(path);
}

static void test_vdb_write_keeps_old(void **state)
{
    (void)state;
    float values[4 * 4 * 4];
    for (int i = 0; i < 64; ++i)
        values[i] = 1.0f;
    const int dims[3] = {4, 4, 4};
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_density_from_dense(values, dims, NULL, NULL, NULL, &density, &err),
                     VDBS_OK);
    const char *path = test_tmp_path("cancel_old.vdb");
    vdbio_write_request request = {0};
    request.density = density;
    assert_int_equal(vdbio_write(path, NULL, &request, &err), VDBS_OK);
    static char before[1 << 16], after[1 << 16];
    long n = file_bytes(path, before, sizeof before);
    vdbs_cancel flag = 2;
    vdbio_meta meta = {"marker", "new"};
    request.file_meta = &meta;
    request.file_meta_count = 1;
    request.cancel = &flag;
    assert_int_equal(vdbio_write(path, NULL, &request, &err), VDBS_ERR_CANCELLED);
    assert_string_equal(err.message, "interrupted");
    assert_int_equal(file_bytes(path, after, sizeof after), n);
    assert_memory_equal(before, after, (size_t)n);
    assert_false(temp_left("cancel_old.vdb"));
    vdbio_density_free(density);
    remove(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kernel_run_stops),
        cmocka_unit_test(test_image_write_keeps_old),
        cmocka_unit_test(test_vdb_write_keeps_old),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
