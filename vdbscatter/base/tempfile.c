/* Temporary output files: naming, stale-file removal and the test-only fault hook. */
#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/tempfile.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#define TEMP_MARK ".tmp."

char *vdbs_temp_path(const char *path)
{
    const char *slash = strrchr(path, '/');
    const size_t dir_len = slash ? (size_t)(slash - path + 1) : 0;
    const size_t n = strlen(path) + 32;
    char *tmp = malloc(n);
    if (tmp)
        snprintf(tmp, n, "%.*s.%s" TEMP_MARK "%ld", (int)dir_len, path, path + dir_len,
                 (long)getpid());
    return tmp;
}

/* The PID of a name ".BASE.tmp.PID" (digits only), or 0 for any other name. */
static long temp_owner(const char *name, const char *base, size_t base_len)
{
    if (name[0] != '.' || strncmp(name + 1, base, base_len) != 0)
        return 0;
    const char *p = name + 1 + base_len;
    if (strncmp(p, TEMP_MARK, strlen(TEMP_MARK)) != 0)
        return 0;
    p += strlen(TEMP_MARK);
    if (*p < '1' || *p > '9' || strlen(p) > 9)
        return 0;
    char *end = NULL;
    const long pid = strtol(p, &end, 10);
    return *end == '\0' ? pid : 0;
}

void vdbs_temp_remove_stale(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const size_t base_len = strlen(base);
    if (base_len == 0)
        return;
    char *dir = slash ? strndup(path, (size_t)(slash - path) + 1) : strdup(".");
    if (!dir)
        return;
    DIR *d = opendir(dir);
    if (!d) {
        free(dir);
        return;
    }
    const long self = (long)getpid();
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        const long pid = temp_owner(e->d_name, base, base_len);
        /* ESRCH only: EPERM means the process lives under another user. */
        if (pid <= 0 || pid == self || kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        const size_t n = strlen(dir) + strlen(e->d_name) + 2;
        char *full = malloc(n);
        if (!full)
            break;
        snprintf(full, n, "%s%s%s", dir, slash ? "" : "/", e->d_name);
        struct stat st;
        if (lstat(full, &st) == 0 && S_ISREG(st.st_mode))
            unlink(full);
        free(full);
    }
    closedir(d);
    free(dir);
}

void vdbs_temp_sync_folder(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *dir = slash ? strndup(path, slash == path ? 1 : (size_t)(slash - path)) : strdup(".");
    if (!dir)
        return;
    const int fd = open(dir, O_RDONLY | O_DIRECTORY);
    if (fd >= 0) {
        (void)fsync(fd);
        close(fd);
    }
    free(dir);
}

vdbs_status vdbs_text_begin(vdbs_text_file *t, const char *path, vdbs_error *err)
{
    t->path = path;
    t->stream = NULL;
    t->tmp = vdbs_temp_path(path);
    if (!t->tmp)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory", path);
    vdbs_temp_remove_stale(path);
    t->stream = fopen(t->tmp, "w");
    if (!t->stream) {
        const int e = errno;
        free(t->tmp);
        t->tmp = NULL;
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    return VDBS_OK;
}

vdbs_status vdbs_temp_sync(const char *tmp, const char *path, vdbs_error *err)
{
    vdbs_fault_point("mid-write", tmp);
    const int fd = open(tmp, O_RDONLY);
    if (fd < 0 || fsync(fd) != 0) {
        const int e = errno;
        if (fd >= 0)
            close(fd);
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: cannot sync %s: %s", path, tmp, strerror(e));
    }
    close(fd);
    return VDBS_OK;
}

vdbs_status vdbs_temp_rename(const char *tmp, const char *dest, const char *path, vdbs_error *err)
{
    vdbs_fault_point("before-rename", NULL);
    if (rename(tmp, dest) != 0)
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: cannot rename %s into place: %s", path, tmp,
                              strerror(errno));
    vdbs_temp_sync_folder(dest);
    return VDBS_OK;
}

vdbs_status vdbs_text_commit(vdbs_text_file *t, vdbs_error *err)
{
    /* A failed fprintf sets the stream's error flag; fflush catches a full disk. */
    int ok = !ferror(t->stream) && fflush(t->stream) == 0;
    const int e = ok ? 0 : errno;
    ok = fclose(t->stream) == 0 && ok;
    vdbs_status st = VDBS_OK;
    if (!ok)
        st = vdbs_error_set(err, VDBS_ERR_IO, "%s: cannot write: %s", t->path,
                            strerror(e ? e : errno));
    else if ((st = vdbs_temp_sync(t->tmp, t->path, err)) == VDBS_OK)
        st = vdbs_temp_rename(t->tmp, t->path, t->path, err);
    if (st != VDBS_OK)
        unlink(t->tmp);
    free(t->tmp);
    t->tmp = NULL;
    t->stream = NULL;
    return st;
}

void vdbs_fault_point(const char *point, const char *tmp)
{
    const char *want = getenv("VDBSCATTER_FAULT");
    if (!want || strcmp(want, point) != 0)
        return;
    if (tmp && strcmp(point, "mid-write") == 0) {
        struct stat st;
        const int fd = open(tmp, O_WRONLY);
        if (fd >= 0 && fstat(fd, &st) == 0 && ftruncate(fd, st.st_size / 2) == 0)
            (void)fsync(fd);
        if (fd >= 0)
            close(fd);
    }
    raise(SIGKILL);
}
