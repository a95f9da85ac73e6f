/* Hostile-file containment: a risky third-party read (OpenVDB, OpenEXR) runs in a forked
 * child that hands its result back through a pipe, so that a crash, abort or
 * out-of-memory kill inside the library becomes an input error instead of taking the
 * process down. See docs/robustness.md, "Hostile input". */
#ifndef VDBSCATTER_CONTAIN_H
#define VDBSCATTER_CONTAIN_H

#include <stddef.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What a contained child handed back: malloc'd bytes (NULL when it wrote nothing). */
typedef struct vdbs_contained {
    char *data;
    size_t size;
} vdbs_contained;

/* Runs child(fd, user) in a forked child; fd is the write end of a pipe that the parent drains
 * into out while the child runs (a pipe, not a memory file, so that a file-size limit on the
 * process, RLIMIT_FSIZE, does not fail the read); the child's return value is its exit status
 * (0: what it wrote is a result). On return VDBS_OK, out holds it (free with
 * vdbs_contain_free). A child killed by a signal or exiting non-zero gives VDBS_ERR_INPUT
 * "PATH: not a valid LIBRARY file (the LIBRARY reader crashed: SIGNAL)"; an interrupted
 * read (SIGINT, SIGTERM) VDBS_ERR_CANCELLED. The child ends with _exit: no atexit handler
 * runs there. Only the calling thread exists in the child, so child must not wait on
 * other threads of the parent (no OpenMP), nor on a lock one of them held at the fork (the C++
 * bridge ends TBB's workers before it calls this: io/contain_tbb.h).
 * Limits: the child gets RLIMIT_CPU of 120 s plus 1 s per 2 MiB of the file (past it,
 * VDBS_ERR_INPUT "... ran past its N s of CPU time"); a child that gains no CPU time, reads
 * nothing and hands back nothing for 60 s (VDBSCATTER_READER_STALL_SECONDS) has stalled: it is
 * killed and the read tried once more, and a second stall is VDBS_ERR_IO. */
vdbs_status vdbs_contain_run(const char *path, const char *library,
                             int (*child)(int fd, void *user), void *user, vdbs_contained *out,
                             vdbs_error *err);

/* Writes all of data to fd (a child's result); 0 on success, -1 on failure. */
int vdbs_contain_write(int fd, const void *data, size_t size);

void vdbs_contain_free(vdbs_contained *result);

/* How many stalled children this process has killed (each retried or reported). */
unsigned vdbs_contain_stalls(void);

#ifdef __cplusplus
}
#endif

#endif
