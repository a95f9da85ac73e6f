/* Command-line parsing shared by every vdbscatter command, the viewer and the bindings (the
 * words go through vdbs_command_run, vdbscatter.h): option tables, the parser, the scene
 * flags, and the JSON pieces of the reports. */
#ifndef VDBSCATTER_COMMAND_OPTIONS_H
#define VDBSCATTER_COMMAND_OPTIONS_H

#include "vdbscatter/lightgrid.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/vdbscatter.h"

#include "context.h"

/* A command's option table: vdbs_arg_option entries (vdbscatter.h) ending with a NULL name. */

/* One parsed option occurrence, in command-line order. */
typedef struct vdbs_options_arg {
    const vdbs_arg_option *option;
    const char *value; /* NULL for flags */
} vdbs_options_arg;

#define VDBS_OPTIONS_MAX_ARGS 256
#define VDBS_OPTIONS_MAX 128 /* entries of one command's option table */

typedef struct vdbs_options_args {
    vdbs_options_arg args[VDBS_OPTIONS_MAX_ARGS];
    int count;
    const char *positional[8];
    int positional_count;
    int help;
} vdbs_options_args;

/* Splits argv (after the command name) by the option table; unknown options, missing
 * values and values given to flags are errors naming the option. */
vdbs_status vdbs_options_parse(int argc, char **argv, const vdbs_arg_option *options,
                               vdbs_options_args *out, vdbs_error *err);

/* What a command's opening needs to know of it (vdbs_command_open). */
typedef struct vdbs_command_spec {
    const char *name; /* "bake": errors read "vdbscatter bake: ..." */
    /* The command, from its parsed words (vdbs_command_open); returns the exit status. */
    int (*run)(const vdbs_options_args *args);
    const vdbs_arg_option *options;
    const char *help;        /* the OUTPUT of --help or -h */
    void (*more_help)(void); /* what --help says after help, or NULL */
    int min_positional, max_positional;
    const char *positional_error; /* the usage error for another count of them */
} vdbs_command_spec;

/* vdbs_command_open's "go on with the command". */
#define VDBS_COMMAND_CONTINUE (-1)

/* The opening every command shares: parses argv (after the command name) by its options
 * into args, prints the help for --help and checks the count of positional arguments.
 * Returns VDBS_COMMAND_CONTINUE, or the exit status to return (a usage error printed). */
int vdbs_command_open(const vdbs_command_spec *command, int argc, char **argv,
                      vdbs_options_args *args);

/* Last value given for an option name, or NULL. */
const char *vdbs_options_value(const vdbs_options_args *args, const char *name);
int vdbs_options_flag(const vdbs_options_args *args, const char *name);
/* The value of -o or --output (the last one given), or NULL. */
const char *vdbs_options_output(const vdbs_options_args *args);

/* Whole-string numbers: finite doubles, integers within [lo, hi]. */
vdbs_status vdbs_options_number(const char *flag, const char *text, double *out, vdbs_error *err);
vdbs_status vdbs_options_integer(const char *flag, const char *text, long lo, long hi, long *out,
                                 vdbs_error *err);
/* "X,Y,Z" (or one number repeated when allow_scalar). */
vdbs_status vdbs_options_triple(const char *flag, const char *text, int allow_scalar, double out[3],
                                vdbs_error *err);
/* --camera PX,PY,PZ:TX,TY,TZ:FOV_DEG: position, target, vertical field of view; up is +Y
 * unless the view is vertical (then -Z is up). width and height stay 0. */
vdbs_status vdbs_options_camera(const char *text, vdbs_camera *camera, vdbs_error *err);

/* The scene options shared by bake and render (and the later tradeoff): --scene, --grid,
 * --density-scale, --albedo, --g, --sun, --point, --env, --method, --quality; a
 * command's option table lists those it takes (render all but --method).
 * Loads --scene first, then applies the flags in order; light flags replace the scene's
 * lights. Validates the result (at least one light unless allow_no_lights). */
vdbs_status vdbs_options_build_scene(const vdbs_options_args *args, vdbs_scene *scene,
                                     int allow_no_lights, vdbs_error *err);

/* 1 when path ends in ext (case-insensitive) after a non-empty file name. */
int vdbs_options_has_extension(const char *path, const char *ext);

/* --size WxH, integers in [1, 16384]. */
vdbs_status vdbs_options_size(const char *text, int *width, int *height, vdbs_error *err);

/* Which scene fields the flags set (VDBS_SCENE_SET_* of render.h): for a lit VDB they go on
 * top of its baked scene. */
unsigned vdbs_options_scene_flags(const vdbs_options_args *args);

/* For the commands that ignore the scene's occluders and fog (bake, render): reads every
 * OBJ occluder once, so that a missing or malformed file is an error before any work
 * ("scene FILE: occluders[I].file: OBJ:LINE: ..."), then warns once (unless quiet) that
 * `command` ignores the occluders and the fog. Nothing happens for a scene without them. */
vdbs_status vdbs_options_scene_occluders(const char *command, const vdbs_options_args *args,
                                         const vdbs_scene *scene, int quiet, vdbs_error *err);

/* JSON pieces of the bake and render reports. */
struct cJSON;
struct cJSON *vdbs_options_json_triple(const double v[3]);
/* "light_grids": {cells, columns, columns_empty, samples_stored} into j. */
void vdbs_options_json_light_grids(struct cJSON *j, const vdbs_light_grid_stats *stats);

/* The options bake and render share: the output, the backend, the scene and its flags
 * (vdbs_options_build_scene), S1 (vdbs_options_s1), --json and -q. */
#define VDBS_OPTIONS_COMMON                                                                        \
    {"-o", VDBS_ARG_VALUE}, {"--output", VDBS_ARG_VALUE}, {"--backend", VDBS_ARG_VALUE},           \
        {"--progress", VDBS_ARG_VALUE}, {"--threads", VDBS_ARG_VALUE},                             \
        {"--json", VDBS_ARG_FLAG}, {"-q", VDBS_ARG_FLAG}, {"--scene", VDBS_ARG_VALUE},             \
        {"--grid", VDBS_ARG_VALUE}, {"--density-scale", VDBS_ARG_VALUE},                           \
        {"--albedo", VDBS_ARG_VALUE}, {"--g", VDBS_ARG_VALUE}, {"--sun", VDBS_ARG_LIST},           \
        {"--point", VDBS_ARG_LIST}, {"--env", VDBS_ARG_LIST}, {"--quality", VDBS_ARG_VALUE},       \
        {"--sky-directions", VDBS_ARG_VALUE}, {"--s1", VDBS_ARG_VALUE},                            \
    {                                                                                              \
        "--s1-oversample", VDBS_ARG_VALUE                                                          \
    }

/* --s1 grid|march and --s1-oversample F (1..16): *march 1 for "march", *oversample 0 when
 * not given (the default). */
vdbs_status vdbs_options_s1(const vdbs_options_args *args, int *march, int *oversample,
                            vdbs_error *err);

/* The help lines of those two flags (bake and render). */
#define VDBS_OPTIONS_S1_HELP                                                                       \
    "  --s1 grid|march          single scattering from light grids (default): one\n"               \
    "                           transmittance sweep per light direction, then a lookup per\n"      \
    "                           point; or by the exact march to every light (the oracle)\n"        \
    "  --s1-oversample F        light-grid samples per smallest voxel length (default: the\n"      \
    "                           quality's, 1 at low and medium, 2 at high and ultra)\n"

/* --max-memory SIZE|none (vdbs_memory_parse): *bytes 0 when not given (the default limit),
 * -1 for none. */
vdbs_status vdbs_options_max_memory(const vdbs_options_args *args, int64_t *bytes, vdbs_error *err);

#define VDBS_OPTIONS_MAX_MEMORY_HELP                                                               \
    "  --max-memory SIZE        refuse, before the large allocations, work estimated to need\n"    \
    "                           more memory than SIZE (512M, 8G, 8GiB, bytes; none: no\n"          \
    "                           limit; default: 75% of the machine's or the cgroup's)\n"

/* --progress and --threads of a command's parsed words, applied to the running command's
 * context until it ends (context.c). Returns VDBS_EXIT_OK, or the exit status of a bad value
 * (said). */
int vdbs_command_run_options(const char *command, const vdbs_options_args *args);

/* --progress and --threads (read by vdbs_command_run for every command that has them). */
#define VDBS_OPTIONS_RUN_HELP                                                                      \
    "  --progress auto|plain|json|none   progress on stderr: auto (default) rewrites a line\n"     \
    "                           on a terminal and prints timestamped lines otherwise;\n"          \
    "                           json: one JSON object a line\n"                                   \
    "  --threads N              worker threads at most (default: every core)\n"

/* "memory": the limit, the resident set the estimate starts from, the estimate by part and
 * each stage's peak resident set (bytes), into j. */
void vdbs_options_json_memory(struct cJSON *j, int64_t limit, int64_t baseline,
                              const vdbs_memory_estimate *estimate, const char *const stages[],
                              const int64_t peaks[], int stage_count, int per_stage);

/* Says "vdbscatter CMD: message" (an ERROR message) and returns the exit status for status
 * (a vdbs_status or an exit status: 2, VDBS_ERR_INPUT, is a usage error). */
int vdbs_command_fail(const char *command, int status, const char *message);

/* Says a WARNING line ("vdbscatter: warning: ..."); user = quiet flag ptr. */
void vdbs_command_warn(void *quiet, const char *message);

/* The solvers' own flags (--pop-res, --fld-limiter, --residual ...), from the library's
 * solver table: each entry declares its options, and the command line takes them from
 * there (solver.h). */

/* Appends every solver option's flag to a command's option table of `count` entries (room
 * for `max`, the terminating {NULL} entry included) and terminates it; returns the new count. */
int vdbs_options_add_solver_flags(vdbs_arg_option *options, int count, int max);

/* Applies `name VALUE` if name is a solver's flag: *handled 1, and the value checked against
 * the option's range (errors name the flag); *handled 0 for any other name. */
vdbs_status vdbs_options_solver_flag(const char *name, const char *value, vdbs_scene *scene,
                                     int *handled, vdbs_error *err);

/* bake --help's list of methods and each one's options, as OUTPUT. */
void vdbs_options_solver_help(void);

#endif
