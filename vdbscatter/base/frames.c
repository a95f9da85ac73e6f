#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/frames.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The token starting at p, if one does: its length and width (0 when p starts none; -1 when
 * p starts a malformed one). */
static long token_at(const char *p, int *width)
{
    *width = 0;
    if (p[0] == '#') {
        long n = 0;
        while (p[n] == '#')
            ++n;
        *width = (int)n;
        return n;
    }
    if (p[0] == '$' && p[1] == 'F') {
        long n = 2;
        while (isdigit((unsigned char)p[n]) && n < 4)
            *width = *width * 10 + (p[n++] - '0');
        return n;
    }
    if (p[0] == '%') {
        if (p[1] == '%')
            return 0; /* a literal percent sign, as printf has it */
        long n = 1;
        while (isdigit((unsigned char)p[n]) && n < 4)
            *width = *width * 10 + (p[n++] - '0');
        return p[n] == 'd' ? n + 1 : -1;
    }
    return 0;
}

vdbs_status vdbs_frame_token_find(const char *path, const char *what, vdbs_frame_token *token,
                                  vdbs_error *err)
{
    memset(token, 0, sizeof *token);
    for (size_t i = 0; path[i];) {
        int width;
        long n = token_at(path + i, &width);
        if (n < 0)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "%s %s: a %% that is not a frame number (%%d, %%04d) or %%%%",
                                  what, path);
        if (n == 0) {
            i += path[i] == '%' ? 2 : 1; /* past "%%" */
            continue;
        }
        if (width > 12)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s %s: frame padding %d is over 12", what,
                                  path, width);
        if (token->length)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s %s: more than one frame number in it",
                                  what, path);
        token->offset = i;
        token->length = (size_t)n;
        token->width = width;
        i += (size_t)n;
    }
    return VDBS_OK;
}

vdbs_status vdbs_frame_path(const char *pattern, const vdbs_frame_token *token, long frame,
                            char *out, size_t size, vdbs_error *err)
{
    int n;
    if (!token->length)
        n = snprintf(out, size, "%s", pattern);
    else
        n = snprintf(out, size, "%.*s%0*ld%s", (int)token->offset, pattern, token->width, frame,
                     pattern + token->offset + token->length);
    if (n < 0 || (size_t)n >= size)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: the path of frame %ld is too long", pattern,
                              frame);
    return VDBS_OK;
}

static int compare_frames(const void *a, const void *b)
{
    long x = *(const long *)a, y = *(const long *)b;
    return (x > y) - (x < y);
}

/* Appends frame, growing the list. */
static vdbs_status push(vdbs_frame_list *list, int *capacity, long frame, vdbs_error *err)
{
    if (list->count >= VDBS_FRAME_LIST_MAX)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--frames: more than %d frames",
                              VDBS_FRAME_LIST_MAX);
    if (list->count == *capacity) {
        int next = *capacity ? 2 * *capacity : 64;
        long *grown = realloc(list->frames, sizeof *grown * (size_t)next);
        if (!grown)
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the frame list");
        list->frames = grown;
        *capacity = next;
    }
    list->frames[list->count++] = frame;
    return VDBS_OK;
}

/* A frame number at *p (digits only), advancing p. */
static int read_number(const char **p, long *value)
{
    if (!isdigit((unsigned char)**p))
        return 0;
    char *end;
    errno = 0;
    long v = strtol(*p, &end, 10);
    if (errno || v > VDBS_FRAME_MAX)
        return 0;
    *p = end;
    *value = v;
    return 1;
}

static vdbs_status parse_item(const char *item, size_t length, vdbs_frame_list *list, int *capacity,
                              vdbs_error *err)
{
    char text[64];
    if (length == 0 || length >= sizeof text)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--frames: expected N, A-B or A-BxS items separated by commas");
    memcpy(text, item, length);
    text[length] = '\0';
    const char *p = text;
    long first, last, step = 1;
    if (!read_number(&p, &first))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--frames: \"%s\" is not a frame number 0..%ld, A-B or A-BxS", text,
                              VDBS_FRAME_MAX);
    last = first;
    if (*p == '-') {
        ++p;
        if (!read_number(&p, &last))
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "--frames: \"%s\": expected the last frame after '-'", text);
        if (*p == 'x') {
            ++p;
            if (!read_number(&p, &step) || step == 0)
                return vdbs_error_set(err, VDBS_ERR_INPUT,
                                      "--frames: \"%s\": expected a step of 1 or more after 'x'",
                                      text);
        }
    }
    if (*p)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--frames: \"%s\" is not a frame number 0..%ld, A-B or A-BxS", text,
                              VDBS_FRAME_MAX);
    if (last < first)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--frames: \"%s\" runs backwards", text);
    for (long f = first; f <= last; f += step) {
        vdbs_status st = push(list, capacity, f, err);
        if (st != VDBS_OK)
            return st;
    }
    return VDBS_OK;
}

/* Sorts and refuses a frame listed twice. */
static vdbs_status finish(vdbs_frame_list *list, vdbs_error *err)
{
    if (list->count > 1)
        qsort(list->frames, (size_t)list->count, sizeof *list->frames, compare_frames);
    for (int i = 1; i < list->count; ++i)
        if (list->frames[i] == list->frames[i - 1])
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--frames: frame %ld is listed twice",
                                  list->frames[i]);
    return VDBS_OK;
}

vdbs_status vdbs_frame_list_parse(const char *text, vdbs_frame_list *list, vdbs_error *err)
{
    memset(list, 0, sizeof *list);
    int capacity = 0;
    vdbs_status st = VDBS_OK;
    const char *p = text;
    while (st == VDBS_OK) {
        const char *comma = strchr(p, ',');
        size_t length = comma ? (size_t)(comma - p) : strlen(p);
        st = parse_item(p, length, list, &capacity, err);
        if (!comma)
            break;
        p = comma + 1;
    }
    if (st == VDBS_OK)
        st = finish(list, err);
    if (st != VDBS_OK)
        vdbs_frame_list_free(list);
    return st;
}

vdbs_status vdbs_frame_list_scan(const char *pattern, const vdbs_frame_token *token,
                                 vdbs_frame_list *list, vdbs_error *err)
{
    memset(list, 0, sizeof *list);
    /* The folder, and the name's parts before and after the token. */
    const char *slash = NULL;
    for (size_t i = 0; i < token->offset; ++i)
        if (pattern[i] == '/')
            slash = pattern + i;
    char folder[4096];
    if (slash)
        snprintf(folder, sizeof folder, "%.*s", (int)(slash - pattern) + 1, pattern);
    else
        snprintf(folder, sizeof folder, ".");
    const char *prefix = slash ? slash + 1 : pattern;
    const size_t prefix_length = (size_t)(pattern + token->offset - prefix);
    const char *suffix = pattern + token->offset + token->length;
    if (strchr(suffix, '/'))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: the frame number must be in the file name, not a folder",
                              pattern);
    DIR *dir = opendir(folder);
    if (!dir)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: cannot list %s: %s", pattern, folder,
                              strerror(errno));
    int capacity = 0;
    vdbs_status st = VDBS_OK;
    const struct dirent *entry;
    while (st == VDBS_OK && (entry = readdir(dir)) != NULL) {
        const char *name = entry->d_name;
        if (strncmp(name, prefix, prefix_length) != 0)
            continue;
        const char *digits = name + prefix_length, *p = digits;
        while (isdigit((unsigned char)*p))
            ++p;
        const long count = (long)(p - digits);
        if (count == 0 || count < token->width ||
            (token->width && count > token->width && digits[0] == '0'))
            continue; /* not this pattern's padding */
        if (strcmp(p, suffix) != 0)
            continue;
        long frame;
        const char *q = digits;
        if (!read_number(&q, &frame) || q != p)
            continue;
        st = push(list, &capacity, frame, err);
    }
    closedir(dir);
    if (st == VDBS_OK)
        st = finish(list, err);
    if (st != VDBS_OK)
        vdbs_frame_list_free(list);
    return st;
}

void vdbs_frame_list_format(const vdbs_frame_list *list, char *out, size_t size)
{
    size_t used = 0;
    if (size)
        out[0] = '\0';
    for (int i = 0; i < list->count;) {
        /* The longest run with one step from here; two frames with a gap stay apart. */
        int j = i;
        long step = 1;
        if (i + 1 < list->count) {
            step = list->frames[i + 1] - list->frames[i];
            j = i + 1;
            while (j + 1 < list->count && list->frames[j + 1] - list->frames[j] == step)
                ++j;
            if (j == i + 1 && step != 1)
                j = i;
        }
        char item[64];
        if (j == i)
            snprintf(item, sizeof item, "%ld", list->frames[i]);
        else if (step == 1)
            snprintf(item, sizeof item, "%ld-%ld", list->frames[i], list->frames[j]);
        else
            snprintf(item, sizeof item, "%ld-%ldx%ld", list->frames[i], list->frames[j], step);
        int n = snprintf(out + used, size > used ? size - used : 0, "%s%s", i ? "," : "", item);
        if (n < 0 || used + (size_t)n >= size) {
            if (size >= 4)
                snprintf(out + size - 4, 4, "...");
            return;
        }
        used += (size_t)n;
        i = j + 1;
    }
}

void vdbs_frame_list_free(vdbs_frame_list *list)
{
    if (!list)
        return;
    free(list->frames);
    list->frames = NULL;
    list->count = 0;
}
