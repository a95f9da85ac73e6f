#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/progress.h"

#include "vdbscatter/message.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

static _Thread_local vdbs_progress_style thread_style;
static _Thread_local const char *thread_source;

void vdbs_progress_set_style(vdbs_progress_style style, const char *source)
{
    thread_style = style;
    thread_source = source;
}

vdbs_progress_style vdbs_progress_get_style(void)
{
    return thread_style;
}

/* Whether progress comes as whole lines (a log) rather than one line rewritten in place. */
static int in_lines(void)
{
    return thread_style == VDBS_PROGRESS_PLAIN || thread_style == VDBS_PROGRESS_JSON;
}

/* UTC, to the second: what farm logs from many machines can be merged on. */
static void timestamp(char *out, size_t size)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    struct tm tm;
    gmtime_r(&ts.tv_sec, &tm);
    strftime(out, size, "%Y-%m-%dT%H:%M:%SZ", &tm);
}

/* A JSON string's body: quotes, backslashes and control characters escaped. */
static void json_escape(const char *text, char *out, size_t size)
{
    size_t n = 0;
    for (const char *p = text ? text : ""; *p && n + 7 < size; ++p) {
        unsigned char c = (unsigned char)*p;
        if (c == '"' || c == '\\')
            n += (size_t)snprintf(out + n, size - n, "\\%c", c);
        else if (c < 0x20)
            n += (size_t)snprintf(out + n, size - n, "\\u%04x", c);
        else
            out[n++] = (char)c;
    }
    out[n < size ? n : size - 1] = '\0';
}

/* A line in the plain or JSON style. */
static void emit_line(const char *event, const char *label, const char *text, const char *fields)
{
    char when[32];
    timestamp(when, sizeof when);
    const char *source = thread_source ? thread_source : "vdbscatter";
    if (thread_style == VDBS_PROGRESS_JSON) {
        char l[256], t[512];
        json_escape(label, l, sizeof l);
        json_escape(text, t, sizeof t);
        vdbs_message_emitf(VDBS_MESSAGE_PROGRESS,
                           "{\"time\": \"%s\", \"command\": \"%s\", \"event\": \"%s\", "
                           "\"label\": \"%s\", \"message\": \"%s\"%s%s}\n",
                           when, source, event, l, t, fields ? ", " : "", fields ? fields : "");
    } else {
        vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "%s %s: %s: %s\n", when, source, label, text);
    }
}

void vdbs_progress_event(const char *event, const char *label, const char *text, const char *fields)
{
    if (thread_style == VDBS_PROGRESS_NONE)
        return;
    if (thread_style == VDBS_PROGRESS_TERMINAL) {
        if (strcmp(event, "stage") != 0)
            vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "%s: %s\n", label, text);
        return;
    }
    emit_line(event, label, text, fields);
}

/* A task's line in the plain or JSON style. */
static void task_line(const vdbs_progress *progress, const char *event, double fraction,
                      double elapsed, double left)
{
    char text[128], fields[128];
    if (fraction < 0.0) {
        snprintf(text, sizeof text, "started");
        snprintf(fields, sizeof fields, "\"fraction\": 0");
    } else if (strcmp(event, "end") == 0) {
        snprintf(text, sizeof text, "done in %.1fs", elapsed);
        snprintf(fields, sizeof fields, "\"fraction\": 1, \"elapsed\": %.3f", elapsed);
    } else {
        snprintf(text, sizeof text, "%.1f%%, %.1fs elapsed, %.1fs left", 100.0 * fraction, elapsed,
                 left);
        snprintf(fields, sizeof fields, "\"fraction\": %.4f, \"elapsed\": %.3f, \"left\": %.3f",
                 fraction, elapsed, left);
    }
    emit_line(event, progress->label, text, fields);
}

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
    if (enabled && in_lines()) {
        progress->last_print = progress->started;
        task_line(progress, "begin", -1.0, 0.0, 0.0);
    }
}

void vdbs_progress_update(vdbs_progress *progress, uint64_t done)
{
    if (!progress || !progress->enabled || progress->total == 0)
        return;
    double now = vdbs_now();
    const int lines = in_lines();
    if (now - progress->last_print < (lines ? VDBS_PROGRESS_PLAIN_PERIOD : 0.25))
        return;
    progress->last_print = now;
    double fraction = (double)done / (double)progress->total;
    double elapsed = now - progress->started;
    double eta = fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    if (lines) {
        task_line(progress, "update", fraction, elapsed, eta);
        return;
    }
    vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "\r%s: %5.1f%%  %.1fs elapsed, %.1fs left   ",
                       progress->label, 100.0 * fraction, elapsed, eta);
}

void vdbs_progress_end(vdbs_progress *progress)
{
    if (!progress || !progress->enabled)
        return;
    if (in_lines()) {
        task_line(progress, "end", 1.0, vdbs_now() - progress->started, 0.0);
        return;
    }
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
