/* Runs a risky read in a forked child (contain.h). */
#define _GNU_SOURCE
#include "vdbscatter/contain.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
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

const void *vdbs_contain_map(int fd, size_t *size)
{
    *size = 0;
    const off_t end = lseek(fd, 0, SEEK_END);
    if (end <= 0)
        return NULL;
    void *data = mmap(NULL, (size_t)end, PROT_READ, MAP_PRIVATE, fd, 0);
    if (data == MAP_FAILED)
        return NULL;
    *size = (size_t)end;
    return data;
}

void vdbs_contain_unmap(const void *data, size_t size)
{
    if (data)
        munmap((void *)data, size);
}

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
                             int (*child)(int fd, void *user), void *user, int *fd_out,
                             vdbs_error *err)
{
    *fd_out = -1;
    const int fd = memfd_create("vdbscatter-read", MFD_CLOEXEC);
    if (fd < 0)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "memfd_create: %s", strerror(errno));
    fflush(NULL); /* buffered output must not be written twice */
    const pid_t pid = fork();
    if (pid < 0) {
        close(fd);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: cannot start the reader: %s", path,
                              strerror(errno));
    }
    if (pid == 0) {
        /* A crash must end the child by its signal, whatever handlers the caller (or a
         * sanitizer) installed, so that the parent sees and names it. */
        const int fatal[] = {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL};
        for (size_t i = 0; i < sizeof fatal / sizeof *fatal; ++i)
            signal(fatal[i], SIG_DFL);
#ifdef VDBS_SANITIZED
        /* A sanitizer's report in the child (an overflow inside the library) ends the child
         * like a crash; a death callback of the caller's (libFuzzer's, which would record
         * the input as a crash of its own) must not run there. */
        __sanitizer_set_death_callback(NULL);
#endif
        /* The kernel's OOM killer should pick the child, never the caller. */
        const int adj = open("/proc/self/oom_score_adj", O_WRONLY | O_CLOEXEC);
        if (adj >= 0) {
            (void)!write(adj, "1000", 4);
            close(adj);
        }
        const int rc = child(fd, user);
        fflush(NULL);
        _exit(rc);
    }
    int wstatus = 0;
    while (waitpid(pid, &wstatus, 0) < 0) {
        if (errno != EINTR) {
            close(fd);
            return vdbs_error_set(err, VDBS_ERR_INTERNAL, "waitpid: %s", strerror(errno));
        }
    }
    if (WIFSIGNALED(wstatus)) {
        const int sig = WTERMSIG(wstatus);
        close(fd);
        if (sig == SIGINT || sig == SIGTERM)
            return vdbs_error_cancelled(err);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: not a valid %s file (the %s reader crashed: %s)", path, library,
                              library, signal_label(sig));
    }
    if (!WIFEXITED(wstatus) || WEXITSTATUS(wstatus) != 0) {
        close(fd);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: not a valid %s file (the %s reader failed, exit status %d)",
                              path, library, library, WEXITSTATUS(wstatus));
    }
    lseek(fd, 0, SEEK_SET);
    *fd_out = fd;
    return VDBS_OK;
}
