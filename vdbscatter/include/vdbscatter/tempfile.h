/* The temporary file every output is written to before it is renamed into place (the VDB,
 * NanoVDB and image writers share it): its name, the removal of ones that killed processes
 * left behind, and a test-only fault hook (docs/robustness.md, "Faults while writing"). */
#ifndef VDBSCATTER_TEMPFILE_H
#define VDBSCATTER_TEMPFILE_H

#include <stdio.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* "DIR/.NAME.tmp.PID" for the output "DIR/NAME": hidden, in the output's folder so that the
 * rename is atomic, and named by the writing process so that a stale one can be recognised.
 * Returns a malloc'd string, or NULL when out of memory. */
char *vdbs_temp_path(const char *path);

/* Removes the ".NAME.tmp.PID" files beside path whose process no longer exists (kill(PID, 0)
 * fails with ESRCH): what a SIGKILL, a crash or a power cut left. A live process's temporary
 * file, another user's included, is left alone; so is every other name. Best effort: a file
 * that cannot be removed stays and is not an error. */
void vdbs_temp_remove_stale(const char *path);

/* Syncs the folder of path after a rename into it, so that the rename itself survives a
 * power cut (the file's data was synced before). Best effort: a folder that cannot be
 * opened or synced is no error (the new file is in place either way). */
void vdbs_temp_sync_folder(const char *path);

/* The last two steps of every output: vdbs_temp_sync puts tmp (written and closed) on the disk,
 * vdbs_temp_rename renames it over dest and syncs the folder. Each passes its fault point
 * ("mid-write", "before-rename") and returns VDBS_ERR_IO naming path, the output asked for;
 * removing tmp after a failure is the caller's (a writer of two files removes both). */
vdbs_status vdbs_temp_sync(const char *tmp, const char *path, vdbs_error *err);
vdbs_status vdbs_temp_rename(const char *tmp, const char *dest, const char *path, vdbs_error *err);

/* A text output (a report, a table) written whole or not at all, like the pictures and VDBs:
 * vdbs_text_begin opens `stream` on path's temporary file; vdbs_text_commit checks every write,
 * flushes and syncs it and renames it over path, or removes it and returns VDBS_ERR_IO naming
 * path (the previous file stays). Commit once for every successful begin. */
typedef struct vdbs_text_file {
    FILE *stream;
    char *tmp;
    const char *path;
} vdbs_text_file;
vdbs_status vdbs_text_begin(vdbs_text_file *t, const char *path, vdbs_error *err);
vdbs_status vdbs_text_commit(vdbs_text_file *t, vdbs_error *err);

/* Test-only: when the environment variable VDBSCATTER_FAULT equals point ("before-write",
 * "mid-write" or "before-rename"), the process kills itself with SIGKILL here, as a power
 * cut or the OOM killer would. For "mid-write", tmp (written and flushed, not yet synced)
 * is first cut to half its length and synced: what a kill in the middle of the write
 * leaves. Unset, it costs one getenv. */
void vdbs_fault_point(const char *point, const char *tmp);

#ifdef __cplusplus
}
#endif

#endif
