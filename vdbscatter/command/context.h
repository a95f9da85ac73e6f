/* The running command's context: what vdbs_command_run (vdbscatter.h) sets for the calling
 * thread while a command runs, and how the commands talk back through it. */
#ifndef VDBSCATTER_COMMAND_CONTEXT_H
#define VDBSCATTER_COMMAND_CONTEXT_H

#include "vdbscatter/progress.h"
#include "vdbscatter/vdbscatter.h"

/* Exit statuses of every command. */
#define VDBS_EXIT_OK 0
#define VDBS_EXIT_FAILURE 1
#define VDBS_EXIT_USAGE 2
#define VDBS_EXIT_PARTIAL 3 /* a frame sequence done in part */

typedef struct vdbs_command_context vdbs_command_context;

/* Starts a context for desc on this thread (its messages go to desc's callback and its
 * OUTPUT into result); *context NULL when out of memory. */
vdbs_status vdbs_command_context_begin(const vdbs_command_desc *desc, vdbs_command_result *result,
                                       vdbs_command_context **context);
/* Ends it: result->output holds the OUTPUT; the thread's previous sink is back. */
void vdbs_command_context_end(vdbs_command_context *context, int exit_status);

/* Says OUTPUT (what the CLI prints on stdout). */
void vdbs_command_out(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;
/* Says "vdbscatter CMD: message" (ERROR) and records message and status in the result
 * (status: a vdbs_status, or exit status 1 or 2). */
void vdbs_command_error(const char *command, int status, const char *message);
/* The caller's cancel flag (NULL: never). */
const vdbs_cancel *vdbs_command_cancel(void);
/* Whether the caller wants PROGRESS messages (their style: progress.h). */
int vdbs_command_progress(void);
/* --progress: the command's style from now on (the caller's was desc.progress). */
void vdbs_command_set_progress(vdbs_progress_style style);
/* --threads: at most `threads` worker threads in every pool (OpenMP, OpenVDB's TBB,
 * OpenBLAS) until the command ends. */
void vdbs_command_set_threads(int threads);
/* Whether the caller wants render's picture back (vdbs_command_desc.keep_image). */
int vdbs_command_keeps_image(void);
/* Hands the picture to the result: rgb and se (may be NULL) are taken over. */
void vdbs_command_give_image(int width, int height, float *rgb, float *se);
/* When the cancel flag is set: says "vdbscatter CMD: interrupted" and returns 128 + its
 * value; else returns status. */
int vdbs_command_interrupted(const char *command, int status);

#endif
