#include "testutil.h"

#include <math.h>
#include <stdio.h>

const char *test_data_path(const char *file)
{
    static char buf[8][4096];
    static int slot;
    char *out = buf[slot++ & 7];
    snprintf(out, 4096, "%s/%s", VDBS_TEST_DATA_DIR, file);
    return out;
}

const char *test_tmp_path(const char *file)
{
    static char buf[8][4096];
    static int slot;
    char *out = buf[slot++ & 7];
    snprintf(out, 4096, "%s/%s", VDBS_TEST_TMP_DIR, file);
    return out;
}

double test_rel_diff(double a, double b)
{
    double m = fmax(fabs(a), fabs(b));
    return m == 0.0 ? 0.0 : fabs(a - b) / m;
}
