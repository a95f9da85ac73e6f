/* Contained reads (contain.h): a stalled reader is killed and tried once more, a second stall is
 * reported, a busy one is left to work. Forks after TBB's work: test_contain_tbb.cpp; crashes
 * and hostile files: test_hostile_cli.py, through the CLI. */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/contain.h"

static int write_ok(int fd, void *user)
{
    (void)user;
    return vdbs_contain_write(fd, "ok", 2) == 0 ? 0 : 3;
}

static void test_stall_once_is_retried(void **state)
{
    (void)state;
    setenv("VDBSCATTER_READER_STALL_SECONDS", "1", 1);
    setenv("VDBSCATTER_FAULT", "reader-stall-once", 1);
    const unsigned before = vdbs_contain_stalls();
    vdbs_contained out;
    vdbs_error err;
    const vdbs_status st = vdbs_contain_run("x.vdb", "OpenVDB", write_ok, NULL, &out, &err);
    unsetenv("VDBSCATTER_FAULT");
    assert_int_equal(st, VDBS_OK);
    assert_int_equal(out.size, 2);
    assert_memory_equal(out.data, "ok", 2);
    vdbs_contain_free(&out);
    assert_int_equal(vdbs_contain_stalls() - before, 1);
}

static void test_second_stall_is_reported(void **state)
{
    (void)state;
    setenv("VDBSCATTER_READER_STALL_SECONDS", "1", 1);
    setenv("VDBSCATTER_FAULT", "reader-stall", 1);
    const unsigned before = vdbs_contain_stalls();
    vdbs_contained out;
    vdbs_error err;
    const vdbs_status st = vdbs_contain_run("x.vdb", "OpenVDB", write_ok, NULL, &out, &err);
    unsetenv("VDBSCATTER_FAULT");
    assert_int_equal(st, VDBS_ERR_IO);
    assert_null(out.data);
    assert_non_null(strstr(err.message, "x.vdb: the OpenVDB reader stopped making progress"));
    assert_int_equal(vdbs_contain_stalls() - before, 2);
}

/* A child that works (CPU time) for longer than the stall window is not a stall. */
static int busy_then_ok(int fd, void *user)
{
    (void)user;
    volatile double x = 0.0;
    for (long i = 0; i < 800000000L; ++i)
        x += 1e-9;
    return x > 0.0 && vdbs_contain_write(fd, "ok", 2) == 0 ? 0 : 3;
}

static void test_busy_reader_is_not_a_stall(void **state)
{
    (void)state;
    setenv("VDBSCATTER_READER_STALL_SECONDS", "1", 1);
    const unsigned before = vdbs_contain_stalls();
    vdbs_contained out;
    vdbs_error err;
    assert_int_equal(vdbs_contain_run("x.vdb", "OpenVDB", busy_then_ok, NULL, &out, &err), VDBS_OK);
    vdbs_contain_free(&out);
    assert_int_equal(vdbs_contain_stalls() - before, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stall_once_is_retried),
        cmocka_unit_test(test_second_stall_is_reported),
        cmocka_unit_test(test_busy_reader_is_not_a_stall),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
