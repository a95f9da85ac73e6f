#include "vdbscatter/message.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

/* Per thread: a binding runs a command on a worker thread while another may run its own. */
static _Thread_local vdbs_message_sink current;

vdbs_message_sink vdbs_message_sink_set(const vdbs_message_sink *sink)
{
    vdbs_message_sink previous = current;
    current = sink ? *sink : (vdbs_message_sink){0};
    return previous;
}

void vdbs_message_emit(vdbs_message_kind kind, const char *text)
{
    if (current.fn) {
        current.fn(current.user, kind, text);
    } else if (kind != VDBS_MESSAGE_OUTPUT) {
        fputs(text, stderr);
        fflush(stderr);
    }
}

void vdbs_message_emitv(vdbs_message_kind kind, const char *fmt, va_list ap)
{
    char small[1024];
    va_list again;
    va_copy(again, ap);
    int n = vsnprintf(small, sizeof small, fmt, ap);
    if (n >= 0 && (size_t)n < sizeof small) {
        vdbs_message_emit(kind, small);
    } else if (n >= 0) {
        /* A long report or table: formatted again into a buffer of its size. */
        char *big = malloc((size_t)n + 1);
        if (big) {
            vsnprintf(big, (size_t)n + 1, fmt, again);
            vdbs_message_emit(kind, big);
            free(big);
        }
    }
    va_end(again);
}

void vdbs_message_emitf(vdbs_message_kind kind, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vdbs_message_emitv(kind, fmt, ap);
    va_end(ap);
}
