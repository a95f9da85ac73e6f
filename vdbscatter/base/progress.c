#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/progress.h"

#include "vdbscatter/message.h"

#include <stdio.h>
#include <time.h>

double vdbs_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void vdbs_progress_begin(vdbs_progress *progress, int enabled, const char *label, uint64_t total)
{
    progress->enabled = enabled;
    progress->label = label;
    progress->total = total;
    progress->started = vdbs_now();
    progress->last_print = 0.0;
}

void vdbs_progress_update(vdbs_progress *progress, uint64_t done)
{
    if (!progress || !progress->enabled || progress->total == 0)
        return;
    double now = vdbs_now();
    if (now - progress->last_print < 0.25)
        return;
    progress->last_print = now;
    double fraction = (double)done / (double)progress->total;
    double elapsed = now - progress->started;
    double eta = fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "\r%s: %5.1f%%  %.1fs elapsed, %.1fs left   ",
                       progress->label, 100.0 * fraction, elapsed, eta);
}

void vdbs_progress_end(vdbs_progress *progress)
{
    if (!progress || !progress->enabled)
        return;
    vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "\r%s: 100.0%%  %.1fs%*s\n", progress->label,
                       vdbs_now() - progress->started, 20, "");
}

const vdbs_cancel *vdbs_progress_cancel(const vdbs_progress *progress)
{
    return progress ? progress->cancel : NULL;
}

int vdbs_progress_cancelled(const vdbs_progress *progress)
{
    return vdbs_cancelled(vdbs_progress_cancel(progress));
}
