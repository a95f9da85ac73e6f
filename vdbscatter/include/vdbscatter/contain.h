/* Hostile-file containment: a risky third-party read (OpenVDB, OpenEXR) runs in a forked
 * child that hands its result back through a memory file, so that a crash, abort or
 * out-of-memory kill inside the library becomes an input error instead of taking the
 * process down. See docs/robustness.md, "Hostile input". */
#ifndef VDBSCATTER_CONTAIN_H
#define VDBSCATTER_CONTAIN_H

#include <stddef.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Runs child(fd, user) in a forked child; fd is an empty memory file (memfd) that the child
 * writes its result into; the child's return value is its exit status (0: fd holds a
 * result). On return VDBS_OK, *fd_out is that file, rewound, for the caller to read and
 * close. A child killed by a signal or exiting non-zero gives VDBS_ERR_INPUT
 * "PATH: not a valid LIBRARY file (the LIBRARY reader crashed: SIGNAL)"; an interrupted
 * read (SIGINT, SIGTERM) VDBS_ERR_CANCELLED. The child ends with _exit: no atexit handler
 * runs there. Only the calling thread exists in the child, so child must not wait on
 * other threads of the parent (no OpenMP; TBB runs its work on the calling thread). */
vdbs_status vdbs_contain_run(const char *path, const char *library,
                             int (*child)(int fd, void *user), void *user, int *fd_out,
                             vdbs_error *err);

/* Writes all of data to fd (a child's result); 0 on success, -1 on failure. */
int vdbs_contain_write(int fd, const void *data, size_t size);

/* Maps the memory file of a child's result read-only; *size its length. NULL (with
 * *size 0) for an empty file or on failure. Unmap with vdbs_contain_unmap. */
const void *vdbs_contain_map(int fd, size_t *size);
void vdbs_contain_unmap(const void *data, size_t size);

#ifdef __cplusplus
}
#endif

#endif
