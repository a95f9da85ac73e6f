#define _POSIX_C_SOURCE 200809L
#include "context.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "vdbscatter/message.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/vdbio.h"

/* OpenBLAS's own pool (the LAPACK behind the phase matrix's SVD), when the LAPACK the
 * program runs with is OpenBLAS; weak, so that any other LAPACK links too. */
extern void openblas_set_num_threads(int threads) __attribute__((weak));
extern int openblas_get_num_threads(void) __attribute__((weak));

struct vdbs_command_context {
    const vdbs_command_desc *desc;
    vdbs_command_result *result;
    FILE *output; /* open_memstream over output_text */
    char *output_text;
    size_t output_size;
    vdbs_message_sink previous;
    vdbs_progress_style progress;
    int threads_before, blas_threads_before; /* 0: --threads not given */
};

/* One command per thread (a binding runs its command on a worker thread). */
static _Thread_local vdbs_command_context *current;

static void on_message(void *user, vdbs_message_kind kind, const char *text)
{
    vdbs_command_context *c = user;
    if (kind == VDBS_MESSAGE_OUTPUT)
        fputs(text, c->output);
    if (c->desc->message)
        c->desc->message(c->desc->message_user, kind, text);
}

vdbs_status vdbs_command_context_begin(const vdbs_command_desc *desc, vdbs_command_result *result,
                                       vdbs_command_context **context)
{
    *context = NULL;
    vdbs_command_context *c = calloc(1, sizeof *c);
    if (!c)
        return VDBS_ERR_NOMEM;
    c->desc = desc;
    c->result = result;
    c->output = open_memstream(&c->output_text, &c->output_size);
    if (!c->output) {
        free(c);
        return VDBS_ERR_NOMEM;
    }
    const vdbs_message_sink sink = {on_message, c};
    c->previous = vdbs_message_sink_set(&sink);
    c->progress = desc->progress >= VDBS_COMMAND_PROGRESS_TERMINAL &&
                          desc->progress <= VDBS_COMMAND_PROGRESS_JSON
                      ? (vdbs_progress_style)desc->progress
                      : VDBS_PROGRESS_NONE;
    vdbs_progress_set_style(c->progress, desc->argc > 0 ? desc->argv[0] : NULL);
    current = c;
    *context = c;
    return VDBS_OK;
}

void vdbs_command_context_end(vdbs_command_context *c, int exit_status)
{
    vdbs_command_result *r = c->result;
    /* A cancel that came after the command's last poll (or to a command that never polls)
     * still ends it as interrupted, as the CLI's signal would. */
    if (exit_status < 128 && c->desc->argc > 0)
        exit_status = vdbs_command_interrupted(c->desc->argv[0], exit_status);
    r->exit_status = exit_status;
    if (c->threads_before > 0) {
        omp_set_num_threads(c->threads_before);
        vdbio_thread_limit(0);
        if (openblas_set_num_threads && c->blas_threads_before > 0)
            openblas_set_num_threads(c->blas_threads_before);
    }
    vdbs_progress_set_style(VDBS_PROGRESS_NONE, NULL);
    fclose(c->output);
    r->output = c->output_text;
    r->output_size = c->output_size;
    vdbs_message_sink_set(&c->previous);
    current = NULL;
    free(c);
}

void vdbs_command_out(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vdbs_message_emitv(VDBS_MESSAGE_OUTPUT, fmt, ap);
    va_end(ap);
}

void vdbs_command_error(const char *command, int status, const char *message)
{
    vdbs_message_emitf(VDBS_MESSAGE_ERROR, "vdbscatter %s: %s\n", command, message);
    if (!current)
        return;
    vdbs_command_result *r = current->result;
    snprintf(r->error, sizeof r->error, "%s", message);
    /* The exit statuses 1 and 2 stand for a failure and for bad input. */
    if (status == 2 || status == VDBS_ERR_INPUT)
        r->status = VDBS_ERR_INPUT;
    else if (status >= VDBS_ERR_IO && status <= VDBS_ERR_CANCELLED)
        r->status = (vdbs_status)status;
    else
        r->status = VDBS_ERR_INTERNAL;
}

const vdbs_cancel *vdbs_command_cancel(void)
{
    return current ? current->desc->cancel : NULL;
}

int vdbs_command_progress(void)
{
    return current && current->progress != VDBS_PROGRESS_NONE;
}

void vdbs_command_set_progress(vdbs_progress_style style)
{
    if (!current)
        return;
    current->progress = style;
    vdbs_progress_set_style(style, current->desc->argc > 0 ? current->desc->argv[0] : NULL);
}

void vdbs_command_set_threads(int threads)
{
    if (!current || threads < 1)
        return;
    /* OpenMP's count is this thread's own; TBB's and OpenBLAS's are the process's */
    if (current->threads_before == 0)
        current->threads_before = omp_get_max_threads();
    omp_set_num_threads(threads);
    vdbio_thread_limit(threads);
    if (openblas_set_num_threads && openblas_get_num_threads) {
        if (current->blas_threads_before == 0)
            current->blas_threads_before = openblas_get_num_threads();
        openblas_set_num_threads(threads);
    }
}

int vdbs_command_keeps_image(void)
{
    return current && current->desc->keep_image;
}

void vdbs_command_give_image(int width, int height, float *rgb, float *se)
{
    if (!current) {
        free(rgb);
        free(se);
        return;
    }
    vdbs_command_result *r = current->result;
    free(r->rgb);
    free(r->se);
    r->width = width;
    r->height = height;
    r->rgb = rgb;
    r->se = se;
}

int vdbs_command_interrupted(const char *command, int status)
{
    const vdbs_cancel *cancel = vdbs_command_cancel();
    if (!vdbs_cancelled(cancel))
        return status;
    vdbs_command_error(command, VDBS_ERR_CANCELLED, VDBS_CANCELLED_MESSAGE);
    return 128 + (int)*cancel;
}
