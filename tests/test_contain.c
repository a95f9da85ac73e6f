/* Contained reads (contain.h): a stalled reader is killed and tried once more, a second stall is
 * reported, a busy one is left to work. Forks after TBB's work: test_contain_tbb.cpp; crashes
 * and hostile files: test_hostile_cli.py, through the CLI. */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "vdbscatter/contain.h"

static int write_ok(int fd, void *user)
{
    (void)user;
    return vdbs_contain_write(fd, "ok", 2) == 0 ? 0 : 3;
}

/* Runs child contained under the test hook fault (NULL: none) with a 1 s stall window;
 * *stalls gets how many stalled children it cost. */
static vdbs_status run_contained(const char *fault, int (*child)(int fd, void *user),
                                 vdbs_contained *out, vdbs_error *err, unsigned *stalls)
{
    setenv("VDBSCATTER_READER_STALL_SECONDS", "1", 1);
    if (fault)
        setenv("VDBSCATTER_FAULT", fault, 1);
    const unsigned before = vdbs_contain_stalls();
    const vdbs_status st = vdbs_contain_run("x.vdb", "OpenVDB", child, NULL, out, err);
    unsetenv("VDBSCATTER_FAULT");
    *stalls = vdbs_contain_stalls() - before;
    return st;
}

static void test_stall_once_is_retried(void **state)
{
    (void)state;
    vdbs_contained out;
    vdbs_error err;
    unsigned stalls;
    assert_int_equal(run_contained("reader-stall-once", write_ok, &out, &err, &stalls), VDBS_OK);
    assert_int_equal(out.size, 2);
    assert_memory_equal(out.data, "ok", 2);
    vdbs_contain_free(&out);
    assert_int_equal(stalls, 1);
}

static void test_second_stall_is_reported(void **state)
{
    (void)state;
    vdbs_contained out;
    vdbs_error err;
    unsigned stalls;
    assert_int_equal(run_contained("reader-stall", write_ok, &out, &err, &stalls), VDBS_ERR_IO);
    assert_null(out.data);
    assert_non_null(strstr(err.message, "x.vdb: the OpenVDB reader stopped making progress"));
    assert_int_equal(stalls, 2);
}

/* A child that works (gains CPU time) for 2.5 times the stall window is not a stall. */
static int busy_then_ok(int fd, void *user)
{
    (void)user;
    volatile double x = 0.0;
    while (clock() < (clock_t)(2.5 * CLOCKS_PER_SEC))
        for (int i = 0; i < 100000; ++i)
            x += 1e-9;
    return x > 0.0 && vdbs_contain_write(fd, "ok", 2) == 0 ? 0 : 3;
}

static void test_busy_reader_is_not_a_stall(void **state)
{
    (void)state;
    vdbs_contained out;
    vdbs_error err;
    unsigned stalls;
    assert_int_equal(run_contained(NULL, busy_then_ok, &out, &err, &stalls), VDBS_OK);
    vdbs_contain_free(&out);
    assert_int_equal(stalls, 0);
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
