#include "vdbscatter/suggest.h"

#include <stdio.h>
#include <string.h>

/* Optimal string alignment distance, capped at cap + 1 so that long words cost little. */
static int edit_distance(const char *a, const char *b, int cap)
{
    enum { MAXLEN = 64 };
    size_t n = strlen(a), m = strlen(b);
    if (n >= MAXLEN || m >= MAXLEN)
        return cap + 1;
    if ((n > m ? n - m : m - n) > (size_t)cap)
        return cap + 1;
    int d[MAXLEN + 1][MAXLEN + 1];
    for (size_t i = 0; i <= n; ++i)
        d[i][0] = (int)i;
    for (size_t j = 0; j <= m; ++j)
        d[0][j] = (int)j;
    for (size_t i = 1; i <= n; ++i) {
        for (size_t j = 1; j <= m; ++j) {
            int cost = a[i - 1] != b[j - 1];
            int best = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < best)
                best = d[i][j - 1] + 1;
            if (d[i - 1][j - 1] + cost < best)
                best = d[i - 1][j - 1] + cost;
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] &&
                d[i - 2][j - 2] + 1 < best)
                best = d[i - 2][j - 2] + 1;
            d[i][j] = best;
        }
    }
    return d[n][m];
}

const char *vdbs_suggest(const char *word, const char *const *candidates)
{
    if (!word || !candidates)
        return NULL;
    size_t len = strlen(word);
    int cap = len <= 4 ? 1 : len <= 8 ? 2 : 3;
    const char *best = NULL;
    int best_d = cap + 1;
    for (const char *const *c = candidates; *c; ++c) {
        int d = edit_distance(word, *c, cap);
        if (d < best_d) {
            best_d = d;
            best = *c;
        }
    }
    /* A prefix the user stopped typing ("--dens") is a plausible typo too. */
    if (!best && len >= 3)
        for (const char *const *c = candidates; *c; ++c)
            if (strncmp(*c, word, len) == 0)
                return *c;
    return best;
}

void vdbs_suggest_hint(const char *word, const char *const *candidates, char *buf, size_t size)
{
    const char *s = vdbs_suggest(word, candidates);
    if (size == 0)
        return;
    if (s)
        snprintf(buf, size, " (did you mean \"%s\"?)", s);
    else
        buf[0] = '\0';
}

void vdbs_join_names(const char *const *names, char *buf, size_t size)
{
    if (size == 0)
        return;
    buf[0] = '\0';
    size_t used = 0;
    for (const char *const *n = names; *n; ++n) {
        int w = snprintf(buf + used, size - used, "%s%s", n == names ? "" : ", ", *n);
        if (w < 0 || (size_t)w >= size - used) {
            if (size >= 4)
                memcpy(buf + size - 4, "...", 4);
            return;
        }
        used += (size_t)w;
    }
}
