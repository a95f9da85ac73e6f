#include "vdbscatter/status.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* The length of the UTF-8 sequence that starts at s (2 to 4 bytes), or 0 when there is none:
 * a lead byte followed by its continuation bytes (overlong forms of 3 and 4 bytes pass). */
static int utf8_sequence(const unsigned char *s)
{
    const int n = s[0] >= 0xc2 && s[0] <= 0xdf
                      ? 2
                      : (s[0] >= 0xe0 && s[0] <= 0xef ? 3 : (s[0] >= 0xf0 && s[0] <= 0xf4 ? 4 : 0));
    for (int i = 1; i < n; ++i)
        if ((s[i] & 0xc0) != 0x80)
            return 0;
    return n;
}

void vdbs_error_clean(char *message)
{
    unsigned char *c = (unsigned char *)message;
    while (*c) {
        if (*c < 0x80) {
            if (*c < 0x20 || *c == 0x7f)
                *c = '?';
            ++c;
            continue;
        }
        const int n = utf8_sequence(c);
        if (n == 0)
            *c++ = '?';
        else
            c += n;
    }
}

vdbs_status vdbs_error_set(vdbs_error *err, vdbs_status status, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        const int n = vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        /* A quoted value (a file's key, an argument of the command line) that fills the buffer
         * to its last byte is cut visibly, so that the message stays one whole line (a full
         * buffer reads as a cut message). */
        static const char cut[] = " [...]";
        if (n >= (int)sizeof err->message - 1)
            memcpy(err->message + sizeof err->message - sizeof cut - 1, cut, sizeof cut);
        vdbs_error_clean(err->message);
    }
    return status;
}

vdbs_status vdbs_error_cancelled(vdbs_error *err)
{
    return vdbs_error_set(err, VDBS_ERR_CANCELLED, "%s", VDBS_CANCELLED_MESSAGE);
}
