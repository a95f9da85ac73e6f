#define _POSIX_C_SOURCE 200809L
#include "interrupt.h"

#include <signal.h>
#include <string.h>

/* The first signal's number; 0 until one comes. */
static vdbs_cancel interrupt_signal;

static void on_signal(int signo)
{
    if (!interrupt_signal)
        interrupt_signal = signo;
}

const vdbs_cancel *cli_interrupt_install(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    /* SA_RESETHAND: a second signal of the kind takes the default action (the user can
     * still kill a stuck process); SA_RESTART: no EINTR in the middle of file I/O. */
    sa.sa_flags = SA_RESETHAND | SA_RESTART;
    /* Both held while the two handlers go in, so that a signal between the two calls waits
     * for its handler rather than taking the default action. */
    sigset_t both, before;
    sigemptyset(&both);
    sigaddset(&both, SIGINT);
    sigaddset(&both, SIGTERM);
    sigprocmask(SIG_BLOCK, &both, &before);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigprocmask(SIG_SETMASK, &before, NULL);
    return &interrupt_signal;
}
