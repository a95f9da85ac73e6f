#include "vdbscatter/readfile.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { READ_CHUNK = 65536 };

vdbs_status vdbs_read_file(const char *path, const char *label, size_t max_bytes, char **bytes,
                           size_t *size, vdbs_error *err)
{
    *bytes = NULL;
    *size = 0;
    if (!label)
        label = path;
    errno = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: cannot open: %s", label,
                              errno ? strerror(errno) : "unknown error");
    size_t cap = 0, len = 0;
    char *buf = NULL;
    vdbs_status st = VDBS_OK;
    /* One byte past max_bytes is read, to tell a file of exactly max_bytes from a larger one. */
    while (len <= max_bytes) {
        if (cap - len < READ_CHUNK + 1) {
            const size_t ncap = cap ? cap * 2 : 4 * READ_CHUNK;
            char *b = realloc(buf, ncap);
            if (!b) {
                st = vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory", label);
                break;
            }
            buf = b;
            cap = ncap;
        }
        size_t want = cap - len - 1;
        if (want > max_bytes + 1 - len)
            want = max_bytes + 1 - len;
        errno = 0;
        const size_t got = fread(buf + len, 1, want, f);
        len += got;
        if (ferror(f)) {
            /* A directory opens but does not read. */
            const int e = errno;
            st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s: cannot read: %s", label,
                                e ? strerror(e) : "read error");
            break;
        }
        if (got == 0 || feof(f))
            break;
    }
    fclose(f);
    if (st == VDBS_OK && len > max_bytes)
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s: larger than %zu bytes", label, max_bytes);
    if (st != VDBS_OK) {
        free(buf);
        return st;
    }
    buf[len] = '\0';
    *bytes = buf;
    *size = len;
    return VDBS_OK;
}
