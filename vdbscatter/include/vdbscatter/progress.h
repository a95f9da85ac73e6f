/* Progress lines for long work, as PROGRESS messages (message.h: stderr by default); silent
 * unless enabled (the CLI enables it only when stderr is a terminal and -q is not given). */
#ifndef VDBSCATTER_PROGRESS_H
#define VDBSCATTER_PROGRESS_H

#include <stdint.h>

#include "vdbscatter/cancel.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_progress {
    int enabled;
    const char *label;
    uint64_t total;
    double started;
    double last_print;
    /* The caller's cancel flag, carried to every loop that counts progress (NULL: never);
     * vdbs_progress_begin leaves it as it is, so zero-initialise the struct first. */
    const vdbs_cancel *cancel;
} vdbs_progress;

/* Monotonic wall-clock seconds. */
double vdbs_now(void);

void vdbs_progress_begin(vdbs_progress *progress, int enabled, const char *label, uint64_t total);
/* Rate-limited to a few updates a second; safe to call often from one thread. */
void vdbs_progress_update(vdbs_progress *progress, uint64_t done);
void vdbs_progress_end(vdbs_progress *progress);
/* progress->cancel, or NULL for a NULL progress. */
const vdbs_cancel *vdbs_progress_cancel(const vdbs_progress *progress);
/* Whether progress->cancel is set (0 for a NULL progress). */
int vdbs_progress_cancelled(const vdbs_progress *progress);

#ifdef __cplusplus
}
#endif

#endif
