#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/memory.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

vdbs_status vdbs_memory_parse(const char *flag, const char *text, int64_t *bytes, vdbs_error *err)
{
    char *end = NULL;
    errno = 0;
    double value = text ? strtod(text, &end) : 0.0;
    if (!text || end == text || errno != 0 || !isfinite(value) || !isdigit((unsigned char)text[0]))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: expected a size such as 512M, 8G or 8GiB, not '%s'", flag,
                              text ? text : "");
    double scale = 1.0;
    const char *unit = end;
    static const char units[] = "KMGT";
    const char *at = *unit ? strchr(units, toupper((unsigned char)*unit)) : NULL;
    if (at) {
        scale = ldexp(1.0, 10 * (int)(at - units + 1));
        ++unit;
        if (*unit == 'i' || *unit == 'I')
            ++unit;
    }
    if (*unit == 'b' || *unit == 'B')
        ++unit;
    if (*unit)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: unknown unit in '%s' (expected K, M, G or T, e.g. 512M, 8G, "
                              "8GiB)",
                              flag, text);
    double b = floor(value * scale);
    if (!(b >= 1.0) || b > ldexp(1.0, 62))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: '%s' is out of range (1 byte to 4 EiB)",
                              flag, text);
    *bytes = (int64_t)b;
    return VDBS_OK;
}

/* The first number after `key` in a text file, times `unit`; -1 if absent or "max". */
static int64_t read_number(const char *path, const char *key, int64_t unit)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[256];
    int64_t value = -1;
    size_t key_len = key ? strlen(key) : 0;
    while (fgets(line, sizeof line, f)) {
        if (key && strncmp(line, key, key_len) != 0)
            continue;
        char *end = NULL;
        long long v = strtoll(line + key_len, &end, 10);
        if (end != line + key_len)
            value = (int64_t)v * unit;
        break;
    }
    fclose(f);
    return value;
}

int64_t vdbs_memory_default_limit(void)
{
    int64_t total = read_number("/proc/meminfo", "MemTotal:", 1024);
    /* cgroup v2, then v1 (whose "no limit" is a huge number, above MemTotal) */
    const char *cgroups[] = {"/sys/fs/cgroup/memory.max",
                             "/sys/fs/cgroup/memory/memory.limit_in_bytes"};
    for (int i = 0; i < 2; ++i) {
        int64_t limit = read_number(cgroups[i], NULL, 1);
        if (limit > 0 && (total <= 0 || limit < total))
            total = limit;
    }
    return total > 0 ? (int64_t)((double)total * VDBS_MEMORY_DEFAULT_SHARE) : 0;
}

int64_t vdbs_memory_rss(void)
{
    int64_t v = read_number("/proc/self/status", "VmRSS:", 1024);
    return v > 0 ? v : 0;
}

int64_t vdbs_memory_peak(void)
{
    int64_t v = read_number("/proc/self/status", "VmHWM:", 1024);
    return v > 0 ? v : 0;
}

int vdbs_memory_reset_peak(void)
{
#ifdef __GLIBC__
    malloc_trim(0); /* what was freed goes back, or it would count as the next stage's */
#endif
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f)
        return 0;
    int ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

void vdbs_memory_format(int64_t bytes, char *text, size_t size)
{
    static const char *units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 5) {
        v /= 1024.0;
        ++u;
    }
    if (u == 0)
        snprintf(text, size, "%lld B", (long long)bytes);
    else
        snprintf(text, size, v < 100.0 ? "%.1f %s" : "%.0f %s", v, units[u]);
}

void vdbs_memory_add(vdbs_memory_estimate *e, const char *name, int64_t bytes)
{
    for (int i = 0; i < e->count; ++i)
        if (strcmp(e->part[i].name, name) == 0) {
            e->part[i].bytes += bytes;
            return;
        }
    if (e->count < VDBS_MEMORY_PARTS) {
        e->part[e->count].name = name;
        e->part[e->count++].bytes = bytes;
    }
}

int64_t vdbs_memory_total(const vdbs_memory_estimate *e)
{
    int64_t sum = 0;
    for (int i = 0; i < e->count; ++i)
        sum += e->part[i].bytes;
    return sum;
}

vdbs_status vdbs_memory_check(const vdbs_memory_estimate *e, int64_t limit,
                              const char *limit_source, const char *what, const char *lower,
                              vdbs_error *err)
{
    int64_t total = vdbs_memory_total(e);
    if (limit <= 0 || total <= limit)
        return VDBS_OK;
    /* the largest part first: it is what the flags named by `lower` shrink */
    int big = 0;
    for (int i = 1; i < e->count; ++i)
        if (e->part[i].bytes > e->part[big].bytes)
            big = i;
    char need[32], part[32], cap[32];
    vdbs_memory_format(total, need, sizeof need);
    vdbs_memory_format(e->count ? e->part[big].bytes : 0, part, sizeof part);
    vdbs_memory_format(limit, cap, sizeof cap);
    return vdbs_error_set(err, VDBS_ERR_INPUT,
                          "needs %s (%s %s for %s) over the %s limit (%s); lower %s or raise "
                          "--max-memory",
                          need, e->count ? e->part[big].name : "", part, what, cap, limit_source,
                          lower);
}
