#include "vdbscatter/status.h"

#include <stdarg.h>
#include <stdio.h>

vdbs_status vdbs_error_set(vdbs_error *err, vdbs_status status, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return status;
}

vdbs_status vdbs_error_cancelled(vdbs_error *err)
{
    return vdbs_error_set(err, VDBS_ERR_CANCELLED, "%s", VDBS_CANCELLED_MESSAGE);
}
