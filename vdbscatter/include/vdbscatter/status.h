/* Status codes and error messages shared by every vdbscatter module. */
#ifndef VDBSCATTER_STATUS_H
#define VDBSCATTER_STATUS_H

#include "vdbscatter/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Library functions return one of these and fill a vdbs_error on failure.
 * VDBS_ERR_INPUT is the user's fault (bad file, flag or scene): the CLI exits 2. */
typedef enum vdbs_status {
    VDBS_OK = 0,
    VDBS_ERR_INPUT = 2,
    VDBS_ERR_IO = 3,
    VDBS_ERR_GPU = 4,
    VDBS_ERR_NOMEM = 5,
    VDBS_ERR_INTERNAL = 6,
    VDBS_ERR_CANCELLED = 7 /* the caller's vdbs_cancel flag was set (cancel.h) */
} vdbs_status;

#define VDBS_ERROR_MAX 1024

typedef struct vdbs_error {
    char message[VDBS_ERROR_MAX];
} vdbs_error;

/* Formats the message into err (when err is not NULL) and returns status. A message longer
 * than the buffer ends in " [...]"; every message is cleaned by vdbs_error_clean. */
VDBS_API vdbs_status vdbs_error_set(vdbs_error *err, vdbs_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The message of VDBS_ERR_CANCELLED. */
#define VDBS_CANCELLED_MESSAGE "interrupted"

/* Sets err to VDBS_CANCELLED_MESSAGE and returns VDBS_ERR_CANCELLED. */
VDBS_API vdbs_status vdbs_error_cancelled(vdbs_error *err);

/* Makes a message one line of valid UTF-8, in place: control characters and bytes that are
 * not part of a UTF-8 sequence (a quoted key or file name may hold either) become '?'.
 * vdbs_error_set applies it to every message. */
VDBS_API void vdbs_error_clean(char *message);

/* Receives non-fatal warnings (one line each, no trailing newline). */
typedef void (*vdbs_warn_fn)(void *user, const char *message);

/* What a message of a command is (vdbscatter.h). The CLI writes OUTPUT on stdout and the rest
 * on stderr. */
typedef enum vdbs_message_kind {
    VDBS_MESSAGE_OUTPUT = 0,   /* reports (--json), help, tables: the command's stdout */
    VDBS_MESSAGE_ERROR = 1,    /* the one line naming what stopped the command */
    VDBS_MESSAGE_WARNING = 2,  /* "vdbscatter: warning: ..." */
    VDBS_MESSAGE_NOTE = 3,     /* summaries on stderr ("rendered 640x480 ... in 2.1s") */
    VDBS_MESSAGE_PROGRESS = 4, /* a progress line: starts with '\r', the last ends in '\n' */
} vdbs_message_kind;

/* Receives each piece of text as it is produced; text holds its own newlines. */
typedef void (*vdbs_message_fn)(void *user, vdbs_message_kind kind, const char *text);

#ifdef __cplusplus
}
#endif

#endif
