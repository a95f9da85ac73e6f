/* The public API of libvdbscatter: what the CLI does, callable from a program or a binding
 * with the same words. A command runs from its command-line words (vdbs_command_run), so
 * every caller parses options the same way; its output, messages and progress come back
 * through a callback, the report text and (render) the picture in a result. Besides: the
 * option tables that bindings build their keywords from, and dense copies of a VDB's grids.
 * Everything here is exported from libvdbscatter.so; nothing else is (docs/api.md). */
#ifndef VDBSCATTER_VDBSCATTER_H
#define VDBSCATTER_VDBSCATTER_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/cancel.h"
#include "vdbscatter/export.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* "MAJOR.MINOR.PATCH" of the library. */
VDBS_API const char *vdbs_version(void);

/* Messages: vdbs_message_kind and vdbs_message_fn of status.h. */

/* Zero-initialise; 0 means "choose the default". */
typedef struct vdbs_command_desc {
    /* The words after `vdbscatter` on a command line: argv[0] is the command ("bake",
     * "render", "compare", "info", "sample", "phase-svd", "tradeoff"), then its arguments.
     * As the CLI: "--help" says the usage as OUTPUT, "--version" the version, and no words
     * (argc 0) the usage as a NOTE with exit status 2. */
    int argc;
    const char *const *argv;
    vdbs_message_fn message; /* NULL: nothing is passed on (OUTPUT is still collected) */
    void *message_user;
    /* Polled by long work (cancel.h). Once set the command stops, leaves no partial output
     * and exits 128 + the flag's value (a signal number; 130 for 2, as after SIGINT). */
    const vdbs_cancel *cancel;
    /* PROGRESS messages during long work, a VDBS_COMMAND_PROGRESS_* (the CLI: TERMINAL when
     * stderr is a terminal, else PLAIN); a command's --progress overrides it. */
    int progress;
    /* render: also return the picture in the result; -o becomes optional. */
    int keep_image;
} vdbs_command_desc;

/* vdbs_command_desc.progress: none; a line rewritten in place; timestamped lines (farm logs);
 * one JSON object a line. */
enum {
    VDBS_COMMAND_PROGRESS_NONE = 0,
    VDBS_COMMAND_PROGRESS_TERMINAL = 1,
    VDBS_COMMAND_PROGRESS_PLAIN = 2,
    VDBS_COMMAND_PROGRESS_JSON = 3
};

typedef struct vdbs_command_result {
    /* The CLI's exit status: 0 success, 1 failure while working, 2 bad input or usage, 3 a
     * frame sequence done in part (some frames failed, or are missing or stale), 128 + N when
     * cancelled. */
    int exit_status;
    vdbs_status status;         /* VDBS_OK, or the kind of failure (VDBS_ERR_INPUT: bad input) */
    char error[VDBS_ERROR_MAX]; /* the ERROR message without its "vdbscatter CMD: " */
    char *output;               /* every OUTPUT text in order, NUL-terminated (never NULL) */
    size_t output_size;
    /* keep_image: the rendered picture, linear RGB, row 0 on top, 3 floats a pixel; se the
     * per-pixel standard errors of a reference render (NULL otherwise). */
    int width, height;
    float *rgb, *se;
} vdbs_command_result;

/* Runs one command. Returns result->exit_status; the result is always filled, and is freed
 * by vdbs_command_result_free. Thread-safe across threads, one command per thread. */
VDBS_API int vdbs_command_run(const vdbs_command_desc *desc, vdbs_command_result *result);
VDBS_API void vdbs_command_result_free(vdbs_command_result *result);

/* The option tables, for bindings that turn keywords into command-line words. */
typedef enum vdbs_arg_kind {
    VDBS_ARG_FLAG = 0,  /* no value */
    VDBS_ARG_VALUE = 1, /* one value (--name VALUE or --name=VALUE); the last given wins */
    VDBS_ARG_LIST = 2,  /* one value each time, every one used (--sun, --point, --env) */
} vdbs_arg_kind;

typedef struct vdbs_arg_option {
    const char *name; /* "--density-scale", "-o" */
    vdbs_arg_kind kind;
} vdbs_arg_option;

/* The commands' names, NULL-terminated. */
VDBS_API const char *const *vdbs_command_names(void);
/* The count of options of command (as vdbs_command_desc.argv[0]), or -1 for an unknown
 * command. */
VDBS_API int vdbs_command_option_count(const char *command);
/* Option `index` (0 <= index < count) of command; VDBS_ERR_INPUT outside. */
VDBS_API vdbs_status vdbs_command_option_get(const char *command, int index,
                                             vdbs_arg_option *option);

/* A grid of a VDB file copied into a dense array over its active bounding box. */
typedef struct vdbs_dense_grid {
    char name[256];
    int channels;  /* 1 (float) or 3 (vec3s) */
    int origin[3]; /* index of values[0]: the active bounding box's minimum (x, y, z) */
    int size[3];   /* voxels along x, y, z; 0 for an empty grid */
    /* index (x, y, z, 1) -> world: rows of the affine map */
    double index_to_world[3][4];
    /* size[2] x size[1] x size[0] x channels floats, x varying fastest: the grid's values,
     * active or not (a lit VDB holds 0 outside its active voxels). NULL for an empty grid. */
    float *values;
} vdbs_dense_grid;

/* Reads grid `name` (NULL: the first grid) of the OpenVDB file at path into out (the grids of
 * a lit VDB, docs/lit-vdb.md). The copy must fit in max_memory bytes (0: the CLI's default
 * limit, 75% of the machine's or the cgroup's memory; < 0: none). Errors (VDBS_ERR_INPUT, one
 * line naming the file): missing, truncated or foreign file, no such grid, a type other than
 * float or vec3s, a copy over the limit. */
VDBS_API vdbs_status vdbs_dense_read(const char *path, const char *name, int64_t max_memory,
                                     vdbs_dense_grid *out, vdbs_error *err);
VDBS_API void vdbs_dense_free(vdbs_dense_grid *grid);

/* Every float and vec3s grid of the file (the first of two with one name), in file order, from
 * one reading of it: *grids is an array of *count, freed by vdbs_dense_free_all. All copies
 * together must fit in max_memory. Errors as vdbs_dense_read's. */
VDBS_API vdbs_status vdbs_dense_read_all(const char *path, int64_t max_memory,
                                         vdbs_dense_grid **grids, int *count, vdbs_error *err);
VDBS_API void vdbs_dense_free_all(vdbs_dense_grid *grids, int count);

#ifdef __cplusplus
}
#endif

#endif
