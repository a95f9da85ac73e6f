/* The C++ bridge's entry to contained reads (vdbscatter/contain.h): oneTBB is not fork-safe. A
 * TBB worker that holds one of TBB's internal locks at the fork (going to sleep after the
 * parent's last parallel algorithm) leaves it held in the child, whose next parallel algorithm
 * (OpenVDB's reads and counts use them) then waits forever: 8 children in 3000 hung so, forked
 * right after parallel work. So the workers end before every contained fork; TBB starts new
 * ones at its next use. */
#ifndef VDBSCATTER_IO_CONTAIN_TBB_H
#define VDBSCATTER_IO_CONTAIN_TBB_H

#include <new>

#include <tbb/global_control.h>

#include "vdbscatter/contain.h"

inline vdbs_status contain_run_without_tbb_workers(const char *path, const char *library,
                                                   int (*child)(int fd, void *user), void *user,
                                                   vdbs_contained *out, vdbs_error *err)
{
    /* false when another thread is inside TBB right now; the stall watch covers that case. */
    tbb::task_scheduler_handle handle{tbb::attach{}};
    (void)tbb::finalize(handle, std::nothrow);
    return vdbs_contain_run(path, library, child, user, out, err);
}

#endif
