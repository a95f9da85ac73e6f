/* Runs a risky read in a forked child (contain.h). */
#define _GNU_SOURCE
#include "vdbscatter/contain.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* A child that neither gains CPU time, nor reads, nor writes for this long has stalled (a lock
 * left held by a parent thread at the fork, a hung file system); VDBSCATTER_READER_STALL_SECONDS
 * overrides it. */
#define CONTAIN_STALL_SECONDS 60
/* The child's CPU budget: a base plus one second per this many bytes of the file, about 40
 * times what OpenVDB needs to read and decompress a large grid here. */
#define CONTAIN_CPU_BASE_SECONDS 120
#define CONTAIN_CPU_BYTES_PER_SECOND (2u << 20)

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

static _Atomic unsigned stalls;

unsigned vdbs_contain_stalls(void)
{
    return stalls;
}

void vdbs_contain_free(vdbs_contained *result)
{
    free(result->data);
    result->data = NULL;
    result->size = 0;
}

/* CPU ticks plus bytes read so far by pid: any change is progress. -1 when /proc cannot tell. */
static long long child_activity(pid_t pid)
{
    char path[64], buf[1024];
    long long activity = 0;
    snprintf(path, sizeof path, "/proc/%d/stat", (int)pid);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    const size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    /* Fields after the command's closing parenthesis; utime and stime are the 12th and 13th. */
    const char *p = strrchr(buf, ')');
    unsigned long long utime = 0, stime = 0;
    if (!p || sscanf(p + 1, " %*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &utime,
                     &stime) != 2)
        return -1;
    activity = (long long)(utime + stime);
    snprintf(path, sizeof path, "/proc/%d/io", (int)pid);
    if ((f = fopen(path, "r")) != NULL) {
        unsigned long long rchar = 0;
        if (fscanf(f, "rchar: %llu", &rchar) == 1)
            activity += (long long)rchar;
        fclose(f);
    }
    return activity;
}

static int stall_seconds(void)
{
    const char *s = getenv("VDBSCATTER_READER_STALL_SECONDS");
    const int v = s ? atoi(s) : 0;
    return v > 0 ? v : CONTAIN_STALL_SECONDS;
}

/* Reads fd to its end into out (grown by doubling) while watching pid: 0 at the end, 1 when the
 * child stalled (nothing read and no activity for stall seconds), -1 with errno set on error. */
static int drain(int fd, pid_t pid, int stall, vdbs_contained *out)
{
    size_t room = 0;
    long long last = child_activity(pid);
    int idle = 0;
    for (;;) {
        if (out->size == room) {
            const size_t grown = room ? 2 * room : 1 << 16;
            char *data = realloc(out->data, grown);
            if (!data)
                return -1;
            out->data = data;
            room = grown;
        }
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        const int ready = poll(&pfd, 1, 1000);
        if (ready < 0 && errno == EINTR)
            continue;
        if (ready < 0)
            return -1;
        if (ready == 0) {
            const long long now = child_activity(pid);
            if (now != last || now < 0) {
                last = now;
                idle = 0;
            } else if (++idle >= stall) {
                return 1;
            }
            continue;
        }
        const ssize_t n = read(fd, out->data + out->size, room - out->size);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -1;
        if (n == 0)
            return 0;
        out->size += (size_t)n;
        idle = 0;
    }
}

/* The child's CPU-time limit for a file of path's size, in seconds. */
static rlim_t cpu_budget(const char *path)
{
    struct stat st;
    const rlim_t extra = stat(path, &st) == 0 && st.st_size > 0
                             ? (rlim_t)st.st_size / CONTAIN_CPU_BYTES_PER_SECOND
                             : 0;
    return CONTAIN_CPU_BASE_SECONDS + extra;
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

/* One forked attempt. *stalled is set when the child stopped making progress and was killed;
 * the caller may try again. */
static vdbs_status contain_attempt(const char *path, const char *library, int attempt,
                                   int (*child)(int fd, void *user), void *user,
                                   vdbs_contained *out, int *stalled, vdbs_error *err)
{
    out->data = NULL;
    out->size = 0;
    *stalled = 0;
    const rlim_t cpu = cpu_budget(path);
    const int stall = stall_seconds();
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
        const int fatal[] = {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGXCPU};
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
        /* A library looping on a hostile file ends by SIGXCPU (SIGKILL a little later). */
        const struct rlimit limit = {cpu, cpu + 5};
        (void)setrlimit(RLIMIT_CPU, &limit);
        /* Test hooks (docs/robustness.md, "Hostile input"): a reader that crashes, one that
         * hangs. */
        const char *fault = getenv("VDBSCATTER_FAULT");
        if (fault && strcmp(fault, "reader-crash") == 0)
            raise(SIGSEGV);
        if (fault && (strcmp(fault, "reader-stall") == 0 ||
                      (strcmp(fault, "reader-stall-once") == 0 && attempt == 0)))
            for (;;)
                pause();
        const int rc = child(ends[1], user);
        fflush(NULL);
        _exit(rc);
    }
    close(ends[1]);
    const int drained = drain(ends[0], pid, stall, out);
    const int drain_errno = errno;
    close(ends[0]);
    if (drained == 1)
        kill(pid, SIGKILL);
    int wstatus = 0;
    while (waitpid(pid, &wstatus, 0) < 0) {
        if (errno != EINTR) {
            vdbs_contain_free(out);
            return vdbs_error_set(err, VDBS_ERR_INTERNAL, "waitpid: %s", strerror(errno));
        }
    }
    if (drained == 1) {
        vdbs_contain_free(out);
        *stalled = 1;
        ++stalls;
        return vdbs_error_set(err, VDBS_ERR_IO,
                              "%s: the %s reader stopped making progress (no CPU time, reads or "
                              "result for %d s, twice): a hung file system?",
                              path, library, stall);
    }
    if (WIFSIGNALED(wstatus)) {
        const int sig = WTERMSIG(wstatus);
        vdbs_contain_free(out);
        if (sig == SIGINT || sig == SIGTERM)
            return vdbs_error_cancelled(err);
        if (sig == SIGXCPU)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "%s: not a valid %s file (the %s reader ran past its %llu s of "
                                  "CPU time)",
                                  path, library, library, (unsigned long long)cpu);
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

vdbs_status vdbs_contain_run(const char *path, const char *library,
                             int (*child)(int fd, void *user), void *user, vdbs_contained *out,
                             vdbs_error *err)
{
    /* A stall is retried once: its likely cause, a lock some thread of the parent held at the
     * fork, does not repeat at the next fork; a second stall is reported. */
    int stalled = 0;
    vdbs_status st = VDBS_OK;
    for (int attempt = 0; attempt < 2; ++attempt) {
        st = contain_attempt(path, library, attempt, child, user, out, &stalled, err);
        if (!stalled)
            break;
    }
    return st;
}
