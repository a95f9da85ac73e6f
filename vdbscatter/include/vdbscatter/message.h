/* Where the library's messages go: the calling thread's sink, which vdbs_command_run sets for
 * the length of a command (vdbscatter.h); without one, everything but OUTPUT goes to stderr
 * (library users who never set a sink keep the progress lines they had). */
#ifndef VDBSCATTER_MESSAGE_H
#define VDBSCATTER_MESSAGE_H

#include <stdarg.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_message_sink {
    vdbs_message_fn fn; /* NULL: the default (stderr; OUTPUT dropped) */
    void *user;
} vdbs_message_sink;

/* Sets this thread's sink (NULL: the default) and returns the one it replaces. */
vdbs_message_sink vdbs_message_sink_set(const vdbs_message_sink *sink);

void vdbs_message_emit(vdbs_message_kind kind, const char *text);
/* Formats a message of any length. */
void vdbs_message_emitv(vdbs_message_kind kind, const char *fmt, va_list ap);
void vdbs_message_emitf(vdbs_message_kind kind, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#ifdef __cplusplus
}
#endif

#endif
