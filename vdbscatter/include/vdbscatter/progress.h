/* Progress lines for long work, as PROGRESS messages (message.h: stderr by default); silent
 * unless enabled. The calling thread's style says how they look: a line rewritten in place on
 * a terminal, or timestamped lines a farm's log can keep (docs/sequences.md, "Logs"). */
#ifndef VDBSCATTER_PROGRESS_H
#define VDBSCATTER_PROGRESS_H

#include <stdint.h>

#include "vdbscatter/cancel.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbs_progress_style {
    VDBS_PROGRESS_NONE = 0,
    VDBS_PROGRESS_TERMINAL, /* one line per task, rewritten in place ('\r') */
    VDBS_PROGRESS_PLAIN,    /* "2026-12-04T22:40:01Z bake: solve svd: 45.0% ..." lines: a start,
                               one every VDBS_PROGRESS_PLAIN_PERIOD seconds, and an end */
    VDBS_PROGRESS_JSON      /* the same as one JSON object a line */
} vdbs_progress_style;

#define VDBS_PROGRESS_PLAIN_PERIOD 10.0

/* The calling thread's style (NONE until set) and the name its lines start with ("bake"). */
void vdbs_progress_set_style(vdbs_progress_style style, const char *source);
vdbs_progress_style vdbs_progress_get_style(void);

/* One line for an event that is not a task's percentage: a stage begun ("stage", "solve svd")
 * or a frame done ("frame", ...). Nothing on a terminal for stages (each stage's task shows
 * itself there); text is the line's message, fields a JSON object's members without braces
 * ("\"frame\": 12") for the JSON style, or NULL. */
void vdbs_progress_event(const char *event, const char *label, const char *text,
                         const char *fields);

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
