/* Frame sequences: the frame token in a path (smoke.####.vdb, smoke.$F4.vdb, smoke.%04d.vdb)
 * and frame lists (--frames 1-240x2,300). docs/sequences.md. */
#ifndef VDBSCATTER_FRAMES_H
#define VDBSCATTER_FRAMES_H

#include <stddef.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Frame numbers are 0 .. VDBS_FRAME_MAX; a list holds at most VDBS_FRAME_LIST_MAX frames. */
#define VDBS_FRAME_MAX 9999999L
#define VDBS_FRAME_LIST_MAX 100000

/* Where a path's frame token is and how it pads: `####` pads to as many digits as there are
 * #s; `$F` does not pad, `$F4` pads to 4; `%d` does not pad, `%04d` (or `%4d`) pads to 4. */
typedef struct vdbs_frame_token {
    size_t offset, length; /* of the token in the path; length 0: the path has none */
    int width;             /* digits padded with zeros to this many; 0: none */
} vdbs_frame_token;

/* Finds the frame token in `path`. No token: VDBS_OK with token->length 0. More than one
 * token, or a malformed one (`$F` or `%` followed by what is not a width and `d`), is
 * VDBS_ERR_INPUT naming `what` (e.g. "-o") and the path. */
vdbs_status vdbs_frame_token_find(const char *path, const char *what, vdbs_frame_token *token,
                                  vdbs_error *err);

/* The path of `frame`: the token replaced by the padded number. VDBS_ERR_INPUT when it does
 * not fit in `size`. */
vdbs_status vdbs_frame_path(const char *pattern, const vdbs_frame_token *token, long frame,
                            char *out, size_t size, vdbs_error *err);

/* A list of frames, ascending, each once. */
typedef struct vdbs_frame_list {
    long *frames;
    int count;
} vdbs_frame_list;

/* Parses --frames: comma-separated items, each N, A-B or A-BxS (every S-th frame from A up to
 * B). A frame listed twice, a range that runs backwards, a step of 0, or more than
 * VDBS_FRAME_LIST_MAX frames is VDBS_ERR_INPUT naming --frames. */
vdbs_status vdbs_frame_list_parse(const char *text, vdbs_frame_list *list, vdbs_error *err);

/* The frames on disk: every file in the pattern's folder whose name is the pattern with
 * digits at the token (as many as the width, or more; any number without one), ascending. */
vdbs_status vdbs_frame_list_scan(const char *pattern, const vdbs_frame_token *token,
                                 vdbs_frame_list *list, vdbs_error *err);

/* The list as --frames text, ranges folded ("1-8,10-20x2"), into out (truncated with "..."
 * when it does not fit). */
void vdbs_frame_list_format(const vdbs_frame_list *list, char *out, size_t size);

void vdbs_frame_list_free(vdbs_frame_list *list);

#ifdef __cplusplus
}
#endif

#endif
