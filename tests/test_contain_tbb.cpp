/* Contained reads forked right after TBB's parallel work (io/contain_tbb.h). oneTBB is not
 * fork-safe: a worker holding one of TBB's locks at the fork leaves it held in the child, whose
 * next parallel algorithm waits forever. Without ending the workers first, 10 children in 4500
 * hung in this loop here (so 2000 rounds miss it 1 time in 100); 2000 rounds with no stall (a
 * 3 s window) says they no longer do. A
 * C++ test because the parent's side of the hazard is TBB's own scheduler state. */
#include <atomic>
#include <cmath>
#include <cstdlib>

#include <tbb/parallel_for.h>

#include "io/contain_tbb.h"

/* After the libraries' headers: cmocka's macros would rewrite their code. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

extern "C" { /* cmocka.h has no C++ guard */
#include <cmocka.h>
}

/* Under AddressSanitizer the loop checks the path's memory, not the hang's statistic (the
 * normal pass has the 2000 rounds): at 6x the cost it would double the sanitized pass. */
#if defined(__SANITIZE_ADDRESS__)
#define ROUNDS 300
#else
#define ROUNDS 2000
#endif

static long parallel_work()
{
    std::atomic<long> sum{0};
    tbb::parallel_for(0, 2000, [&](int i) {
        double x = 0.0;
        for (int k = 0; k < 2000; ++k)
            x += std::sqrt(double(i + k));
        sum += static_cast<long>(x);
    });
    return sum;
}

static int child_works_in_parallel(int fd, void *user)
{
    (void)user;
    return parallel_work() > 0 && vdbs_contain_write(fd, "ok", 2) == 0 ? 0 : 3;
}

static void test_forks_after_parallel_work(void **state)
{
    (void)state;
    setenv("VDBSCATTER_READER_STALL_SECONDS", "3", 1);
    const unsigned before = vdbs_contain_stalls();
    for (int round = 0; round < ROUNDS; ++round) {
        assert_true(parallel_work() > 0);
        vdbs_contained out;
        vdbs_error err;
        assert_int_equal(contain_run_without_tbb_workers(
                             "x.vdb", "OpenVDB", child_works_in_parallel, nullptr, &out, &err),
                         VDBS_OK);
        assert_int_equal(out.size, 2);
        vdbs_contain_free(&out);
    }
    assert_int_equal(vdbs_contain_stalls() - before, 0);
}

int main()
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forks_after_parallel_work),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
