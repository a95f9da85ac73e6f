/* Bounded memory (docs/robustness.md "Bounded memory"): the --max-memory limit, its default,
 * and the process's resident memory as Linux reports it. Each module that allocates in
 * proportion to the input reports its bytes for a plan next to its allocations (e.g.
 * vdbs_light_grids_estimate); bake and render add them up and refuse, before the large
 * allocations, a plan over the limit. */
#ifndef VDBSCATTER_MEMORY_H
#define VDBSCATTER_MEMORY_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The default limit's share of the machine: of MemTotal, or of the cgroup's limit where
 * lower (the rest is for the system, the viewer and other processes). */
#define VDBS_MEMORY_DEFAULT_SHARE 0.75
/* Where a default limit comes from, as the over-limit message says it. */
#define VDBS_MEMORY_DEFAULT_SOURCE "default: 75% of this machine's or cgroup's memory"

/* "512M", "8G", "8GiB", "1.5G", "4096" (bytes); K, M, G, T are powers of 1024, with an
 * optional "B" or "iB". VDBS_ERR_INPUT naming `flag` for anything else, 0 or over 2^62. */
vdbs_status vdbs_memory_parse(const char *flag, const char *text, int64_t *bytes, vdbs_error *err);

/* VDBS_MEMORY_DEFAULT_SHARE of the smaller of /proc/meminfo's MemTotal and the cgroup's limit
 * (v2 memory.max, v1 memory.limit_in_bytes); 0 when neither can be read (no limit). */
int64_t vdbs_memory_default_limit(void);

/* The process's resident set now (VmRSS) and its peak (VmHWM), in bytes; 0 when unknown. */
int64_t vdbs_memory_rss(void);
int64_t vdbs_memory_peak(void);
/* Resets the peak to the current resident set (writes "5" to /proc/self/clear_refs, Linux
 * 4.0 and later), so that the next vdbs_memory_peak is a stage's own; 0 when refused (the
 * peak then stays the process's). */
int vdbs_memory_reset_peak(void);

/* "31.2 GiB", "512 MiB", "4.0 KiB", "100 B". */
void vdbs_memory_format(int64_t bytes, char *text, size_t size);

/* What a bake or render would hold at its peak, by part, and the check against a limit. */
#define VDBS_MEMORY_PARTS 8
typedef struct vdbs_memory_estimate {
    int count;
    struct {
        const char *name; /* "volume", "outputs", "light grids", ... (static strings) */
        int64_t bytes;
    } part[VDBS_MEMORY_PARTS];
} vdbs_memory_estimate;

void vdbs_memory_add(vdbs_memory_estimate *estimate, const char *name, int64_t bytes);
int64_t vdbs_memory_total(const vdbs_memory_estimate *estimate);

/* VDBS_OK when limit <= 0 (none) or the total fits; else VDBS_ERR_INPUT with one line:
 * "needs 31.2 GiB (light grids 30.1 GiB: 257 at --quality high, ...) over the 18 GiB limit
 * (--max-memory); lower ..." where `what` says what the largest part is made of and `lower`
 * which flags shrink it. */
vdbs_status vdbs_memory_check(const vdbs_memory_estimate *estimate, int64_t limit,
                              const char *limit_source, const char *what, const char *lower,
                              vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
