/* Reading a whole input file into memory: the scene, OBJ and Radiance HDR readers parse
 * from one buffer, so that what they check is what they decode. */
#ifndef VDBSCATTER_READFILE_H
#define VDBSCATTER_READFILE_H

#include "vdbscatter/status.h"

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Reads the file at path, at most max_bytes, into a malloc'd buffer with a NUL after its
 * *size bytes (so text parsers may treat it as a string). It is read in chunks with no size
 * query, since a directory or a pipe reports none. label names the file in messages
 * ("scene a.json"; NULL: path). A missing, unreadable or larger file is VDBS_ERR_INPUT. */
vdbs_status vdbs_read_file(const char *path, const char *label, size_t max_bytes, char **bytes,
                           size_t *size, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
