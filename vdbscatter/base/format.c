#include "vdbscatter/format.h"

#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

void vdbs_format_double(double v, char *buf, size_t size)
{
    if (!isfinite(v)) {
        snprintf(buf, size, "null");
        return;
    }
    for (int prec = 15; prec <= 17; ++prec) {
        snprintf(buf, size, "%.*g", prec, v);
        if (strtod(buf, NULL) == v)
            break;
    }
    /* printf follows the C locale's decimal point; the text always uses '.'. */
    const char *dp = localeconv()->decimal_point;
    if (dp && dp[0] && dp[0] != '.' && !dp[1])
        for (char *p = buf; *p; ++p)
            if (*p == dp[0])
                *p = '.';
}
