/* Frame sequences for bake and render (docs/sequences.md): the frame list, the per-frame paths,
 * skipping frames that are done, the per-frame reports, the sequence summary, progress lines
 * per frame and the exit status. The command supplies a frame's work and, for skipping, the
 * hash of what determines a frame's output. */
#ifndef VDBSCATTER_COMMAND_SEQUENCE_H
#define VDBSCATTER_COMMAND_SEQUENCE_H

#include <cjson/cJSON.h>

#include "options.h"
#include "vdbscatter/frames.h"

#define VDBS_SEQUENCE_PATH_MAX 4096
#define VDBS_SEQUENCE_HASH_SIZE 33 /* 128 bits in hex, and the NUL */

/* The metadata key of a lit VDB's determinants hash, and of its frame and rate. */
#define VDBS_SEQUENCE_META_HASH "vdbscatter_hash"
#define VDBS_SEQUENCE_META_FRAME "vdbscatter_frame"
#define VDBS_SEQUENCE_META_FPS "vdbscatter_fps"

/* The sequence options every command with sequences takes. */
#define VDBS_SEQUENCE_OPTIONS                                                                      \
    {"--frames", VDBS_ARG_VALUE}, {"--skip-missing", VDBS_ARG_FLAG}, {"--fps", VDBS_ARG_VALUE},    \
    {                                                                                              \
        "--summary", VDBS_ARG_VALUE                                                                \
    }

/* One frame as the command's work sees it. */
typedef struct vdbs_sequence_frame {
    long frame;
    int index; /* in the list */
    char input[VDBS_SEQUENCE_PATH_MAX], output[VDBS_SEQUENCE_PATH_MAX];
    /* The previous frame of the list when it is done or up to date in this run (a warm
     * start's source), else NULL. */
    const char *previous_output;
    char hash[VDBS_SEQUENCE_HASH_SIZE]; /* filled by the hash step */
    double fps;                         /* --fps, or 0 */
} vdbs_sequence_frame;

typedef struct vdbs_sequence_step {
    const char *command; /* "bake" */
    const char *worked;  /* a worked frame's status: "baked" */
    /* The hash of everything that determines the frame's output, into frame->hash; NULL: a
     * command whose outputs are never skipped. Returns an exit status (the error said). */
    int (*hash)(void *user, vdbs_sequence_frame *frame);
    /* The frame's work: returns its exit status (the error said) and its report (a cJSON
     * object the sequence takes over), or NULL. */
    int (*run)(void *user, const vdbs_sequence_frame *frame, cJSON **report);
    void *user;
    /* The frame's output counts as done only when its metadata carries the frame's hash; the
     * command's own flags: --force works every frame, --verify none (it checks). */
    int force, verify;
    int quiet;
    const char *report_pattern; /* --report with a frame number: one report per frame */
} vdbs_sequence_step;

/* Whether the words ask for a sequence: --frames, or a frame number in the input or output. */
int vdbs_sequence_requested(const vdbs_options_args *args, const char *input, const char *output);

/* The sequence of the words (--frames, or the input pattern's frames on disk; --skip-missing,
 * --fps, --summary, --json, -q): checks the patterns, lists missing inputs (exit 2 unless
 * --skip-missing), then works every frame through `step` (or checks it, with step->verify),
 * writing --summary after each and printing it with --json. Returns the exit status: 0, 2,
 * 3 when some frames failed or (verify) are not done, a failure's status when no frame could
 * be done, or 128 + N when interrupted. */
int vdbs_sequence_run(const vdbs_options_args *args, const char *input, const char *output,
                      const vdbs_sequence_step *step);

/* For words that are no sequence: refuses a sequence-only flag (--skip-missing, --fps,
 * --summary, and the command's `own`, NULL-terminated or NULL) with exit 2, naming it.
 * Returns VDBS_EXIT_OK when none is given. */
int vdbs_sequence_refuse_flags(const char *command, const vdbs_options_args *args,
                               const char *const *own);

/* The 128-bit XXH3 hash of text, in hex. */
void vdbs_sequence_hash_text(const char *text, char hash[VDBS_SEQUENCE_HASH_SIZE]);
/* The same of a file's bytes (--hash-inputs); VDBS_ERR_IO when it cannot be read. */
vdbs_status vdbs_sequence_hash_file(const char *path, char hash[VDBS_SEQUENCE_HASH_SIZE],
                                    vdbs_error *err);

#endif
