/* Runs a risky read in a forked child (contain.h). */
#define _GNU_SOURCE
#include "vdbscatter/contain.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#define VDBS_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VDBS_SANITIZED 1
#endif
#endif
#ifdef VDBS_SANITIZED
#include <sanitizer/common_interface_defs.h>
#endif

int vdbs_contain_write(int fd, const void *data, size_t size)
{
    const char *p = data;
    while (size > 0) {
        const ssize_t n = write(fd, p, size);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            return -1;
        p += n;
        size -= (size_t)n;
    }
    return 0;
}

void vdbs_contain_free(vdbs_contained *result)
{
    free(result->data);
    result->data = NULL;
    result->size = 0;
}

/* Reads fd to its end into out (grown by doubling); 0, or -1 with errno set. */
static int drain(int fd, vdbs_contained *out)
{
    size_t room = 0;
    for (;;) {
        if (out->size == room) {
            const size_t grown = room ? 2 * room : 1 << 16;
            char *data = realloc(out->data, grown);
            if (!data)
                return -1;
            out->data = data;
            room = grown;
        }
        const ssize_t n = read(fd, out->data + out->size, room - out->size);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -1;
        if (n == 0)
            return 0;
        out->size += (size_t)n;
    }
}

#ifdef VDBS_SANITIZED
static void die_by_abort(void)
{
    signal(SIGABRT, SIG_DFL);
    abort();
}
#endif

static const char *signal_label(int sig)
{
    switch (sig) {
    case SIGSEGV:
        return "segmentation fault";
    case SIGBUS:
        return "bus error";
    case SIGABRT:
        return "abort";
    case SIGFPE:
        return "arithmetic exception";
    case SIGILL:
        return "illegal instruction";
    case SIGKILL:
        return "killed, out of memory?";
    default:
        return strsignal(sig);
    }
}

vdbs_status vdbs_contain_run(const char *path, const char *library,
                             int (*child)(int fd, void *user), void *user, vdbs_contained *out,
                             vdbs_error *err)
{
    out->data = NULL;
    out->size = 0;
    int ends[2];
    if (pipe2(ends, O_CLOEXEC) != 0)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "pipe: %s", strerror(errno));
    fflush(NULL); /* buffered output must not be written twice */
    const pid_t pid = fork();
    if (pid < 0) {
        close(ends[0]);
        close(ends[1]);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: cannot start the reader: %s", path,
                              strerror(errno));
    }
    if (pid == 0) {
        close(ends[0]);
        /* A crash must end the child by its signal, whatever handlers the caller (or a
         * sanitizer) installed, so that the parent sees and names it. */
        const int fatal[] = {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL};
        for (size_t i = 0; i < sizeof fatal / sizeof *fatal; ++i)
            signal(fatal[i], SIG_DFL);
#ifdef VDBS_SANITIZED
        /* A sanitizer's report in the child (an overflow inside the library) ends the child
         * like a crash, by SIGABRT; a death callback of the caller's (libFuzzer's, which would
         * record the input as a crash of its own) must not run there. */
        __sanitizer_set_death_callback(die_by_abort);
#endif
        /* The child's own errors and warnings travel back through the pipe; what a library
         * or a sanitizer prints while failing would break the caller's one-line error. */
        const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
        if (null >= 0) {
            dup2(null, STDERR_FILENO);
            close(null);
        }
        /* The kernel's OOM killer should pick the child, never the caller. */
        const int adj = open("/proc/self/oom_score_adj", O_WRONLY | O_CLOEXEC);
        if (adj >= 0) {
            (void)!write(adj, "1000", 4);
            close(adj);
        }
        const int rc = child(ends[1], user);
        fflush(NULL);
        _exit(rc);
    }
    close(ends[1]);
    const int drained = drain(ends[0], out);
    const int drain_errno = errno;
    close(ends[0]);
    int wstatus = 0;
    while (waitpid(pid, &wstatus, 0) < 0) {
        if (errno != EINTR) {
            vdbs_contain_free(out);
            return vdbs_error_set(err, VDBS_ERR_INTERNAL, "waitpid: %s", strerror(errno));
        }
    }
    if (WIFSIGNALED(wstatus)) {
        const int sig = WTERMSIG(wstatus);
        vdbs_contain_free(out);
        if (sig == SIGINT || sig == SIGTERM)
            return vdbs_error_cancelled(err);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: not a valid %s file (the %s reader crashed: %s)", path, library,
                              library, signal_label(sig));
    }
    if (!WIFEXITED(wstatus) || WEXITSTATUS(wstatus) != 0) {
        vdbs_contain_free(out);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: not a valid %s file (the %s reader failed, exit status %d)",
                              path, library, library, WEXITSTATUS(wstatus));
    }
    if (drained != 0) {
        vdbs_contain_free(out);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: reading the %s reader's result: %s", path,
                              library, strerror(drain_errno));
    }
    return VDBS_OK;
}
