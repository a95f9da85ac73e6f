/* Cancelling long library work from outside (the CLI's SIGINT/SIGTERM handler). */
#ifndef VDBSCATTER_CANCEL_H
#define VDBSCATTER_CANCEL_H

#include <signal.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A flag the caller owns: 0 means go on, anything else means stop. A signal handler may set
 * it (it is the one type C lets a handler write); the library only reads it, at stage
 * boundaries and in its long loops, and then returns VDBS_ERR_CANCELLED. A NULL pointer
 * means never cancelled. */
typedef volatile sig_atomic_t vdbs_cancel;

static inline int vdbs_cancelled(const vdbs_cancel *cancel)
{
    return cancel && *cancel != 0;
}

#ifdef __cplusplus
}
#endif

#endif
