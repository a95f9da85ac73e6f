/* Numbers as text that reads back exactly: scene JSON and the lit VDB's metadata. */
#ifndef VDBSCATTER_FORMAT_H
#define VDBSCATTER_FORMAT_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The shortest of %.15g, %.16g and %.17g that strtod reads back as v, with '.' as the
 * decimal point whatever the locale; "null" for a non-finite v (JSON has no other). */
void vdbs_format_double(double v, char *buf, size_t size);

#ifdef __cplusplus
}
#endif

#endif
