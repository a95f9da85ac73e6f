/* Shared by the fuzz harnesses (one per fuzz_X.c, see docs/robustness.md "Fuzzing"): the
 * input as a file for the readers that take a path, and the checks every error must pass. */
#ifndef VDBSCATTER_FUZZ_UTIL_H
#define VDBSCATTER_FUZZ_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "vdbscatter/status.h"

/* Writes data to a file of this process ending in `ext` (".vdb"); the path stays valid until
 * the next call. Aborts when the file cannot be written: that is no finding but a broken
 * setup, which must not pass silently. */
static inline const char *fuzz_file(const uint8_t *data, size_t size, const char *ext)
{
    static char path[512];
    const char *dir = getenv("TMPDIR");
    snprintf(path, sizeof path, "%s/vdbscatter-fuzz-%ld%s", dir && *dir ? dir : "/tmp",
             (long)getpid(), ext);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        fprintf(stderr, "fuzz: cannot write %s\n", path);
        abort();
    }
    return path;
}

/* The project's rule for bad input: a status the CLI reports as the user's fault or a
 * resource limit, never an internal error, and one non-empty line naming the problem. */
static inline void fuzz_check_error(vdbs_status st, const vdbs_error *err, const char *what)
{
    if (st == VDBS_OK)
        return;
    const char *m = err->message;
    if (st != VDBS_ERR_INPUT && st != VDBS_ERR_NOMEM) {
        fprintf(stderr, "fuzz: %s: status %d for bad input: %s\n", what, (int)st, m);
        abort();
    }
    if (m[0] == '\0' || strchr(m, '\n') || strlen(m) >= sizeof err->message - 1) {
        fprintf(stderr, "fuzz: %s: error message not one line: \"%s\"\n", what, m);
        abort();
    }
}

#endif
