/* Command-line parsing shared by every vdbscatter command. */
#ifndef VDBSCATTER_CLI_OPTIONS_H
#define VDBSCATTER_CLI_OPTIONS_H

#include "vdbscatter/lightgrid.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"

/* Exit statuses of every command. */
#define CLI_EXIT_OK 0
#define CLI_EXIT_FAILURE 1
#define CLI_EXIT_USAGE 2

typedef enum cli_arg_kind {
    CLI_FLAG,  /* no value */
    CLI_VALUE, /* --name VALUE or --name=VALUE */
} cli_arg_kind;

typedef struct cli_option {
    const char *name; /* "--sun", "-o" */
    cli_arg_kind kind;
} cli_option;

/* One parsed option occurrence, in command-line order. */
typedef struct cli_arg {
    const cli_option *option;
    const char *value; /* NULL for flags */
} cli_arg;

#define CLI_MAX_ARGS 256
#define CLI_MAX_OPTIONS 128 /* entries of one command's option table */

typedef struct cli_args {
    cli_arg args[CLI_MAX_ARGS];
    int count;
    const char *positional[8];
    int positional_count;
    int help;
} cli_args;

/* Splits argv (after the command name) by the option table; unknown options, missing
 * values and values given to flags are errors naming the option. */
vdbs_status cli_parse(int argc, char **argv, const cli_option *options, cli_args *out,
                      vdbs_error *err);

/* What a command's opening needs to know of it (cli_open). */
typedef struct cli_command {
    const char *name; /* "bake": errors read "vdbscatter bake: ..." */
    const cli_option *options;
    const char *help;        /* printed on stdout for --help or -h */
    void (*more_help)(void); /* what --help prints after help, or NULL */
    int min_positional, max_positional;
    const char *positional_error; /* the usage error for another count of them */
} cli_command;

/* cli_open's "go on with the command". */
#define CLI_CONTINUE (-1)

/* The opening every command shares: parses argv (after the command name) by its options
 * into args, prints the help for --help and checks the count of positional arguments.
 * Returns CLI_CONTINUE, or the exit status to return (a usage error printed). */
int cli_open(const cli_command *command, int argc, char **argv, cli_args *args);

/* Last value given for an option name, or NULL. */
const char *cli_value(const cli_args *args, const char *name);
int cli_flag(const cli_args *args, const char *name);
/* The value of -o or --output (the last one given), or NULL. */
const char *cli_output(const cli_args *args);

/* Whole-string numbers: finite doubles, integers within [lo, hi]. */
vdbs_status cli_number(const char *flag, const char *text, double *out, vdbs_error *err);
vdbs_status cli_integer(const char *flag, const char *text, long lo, long hi, long *out,
                        vdbs_error *err);
/* "X,Y,Z" (or one number repeated when allow_scalar). */
vdbs_status cli_triple(const char *flag, const char *text, int allow_scalar, double out[3],
                       vdbs_error *err);
/* --camera PX,PY,PZ:TX,TY,TZ:FOV_DEG: position, target, vertical field of view; up is +Y
 * unless the view is vertical (then -Z is up). width and height stay 0. */
vdbs_status cli_camera(const char *text, vdbs_camera *camera, vdbs_error *err);

/* The scene options shared by bake and render (and the later tradeoff): --scene, --grid,
 * --density-scale, --albedo, --g, --sun, --point, --env, --method, --quality; a
 * command's option table lists those it takes (render all but --method).
 * Loads --scene first, then applies the flags in order; light flags replace the scene's
 * lights. Validates the result (at least one light unless allow_no_lights). */
vdbs_status cli_build_scene(const cli_args *args, vdbs_scene *scene, int allow_no_lights,
                            vdbs_error *err);

/* 1 when path ends in ext (case-insensitive) after a non-empty file name. */
int cli_has_extension(const char *path, const char *ext);

/* --size WxH, integers in [1, 16384]. */
vdbs_status cli_size(const char *text, int *width, int *height, vdbs_error *err);

/* Which scene fields the flags set (VDBS_SCENE_SET_* of render.h): for a lit VDB they go on
 * top of its baked scene. */
unsigned cli_scene_flags(const cli_args *args);

/* For the commands that ignore the scene's occluders and fog (bake, render): reads every
 * OBJ occluder once, so that a missing or malformed file is an error before any work
 * ("scene FILE: occluders[I].file: OBJ:LINE: ..."), then warns once (unless quiet) that
 * `command` ignores the occluders and the fog. Nothing happens for a scene without them. */
vdbs_status cli_scene_occluders(const char *command, const cli_args *args, const vdbs_scene *scene,
                                int quiet, vdbs_error *err);

/* JSON pieces of the bake and render reports. */
struct cJSON;
struct cJSON *cli_json_triple(const double v[3]);
/* "light_grids": {cells, columns, columns_empty, samples_stored} into j. */
void cli_json_light_grids(struct cJSON *j, const vdbs_light_grid_stats *stats);

/* The options bake and render share: the output, the backend, the scene and its flags
 * (cli_build_scene), S1 (cli_s1_options), --json and -q. */
#define CLI_COMMON_OPTIONS                                                                         \
    {"-o", CLI_VALUE}, {"--output", CLI_VALUE}, {"--backend", CLI_VALUE}, {"--json", CLI_FLAG},    \
        {"-q", CLI_FLAG}, {"--scene", CLI_VALUE}, {"--grid", CLI_VALUE},                           \
        {"--density-scale", CLI_VALUE}, {"--albedo", CLI_VALUE}, {"--g", CLI_VALUE},               \
        {"--sun", CLI_VALUE}, {"--point", CLI_VALUE}, {"--env", CLI_VALUE},                        \
        {"--quality", CLI_VALUE}, {"--sky-directions", CLI_VALUE}, {"--s1", CLI_VALUE},            \
    {                                                                                              \
        "--s1-oversample", CLI_VALUE                                                               \
    }

/* --s1 grid|march and --s1-oversample F (1..16): *march 1 for "march", *oversample 0 when
 * not given (the default). */
vdbs_status cli_s1_options(const cli_args *args, int *march, int *oversample, vdbs_error *err);

/* The help lines of those two flags (bake and render). */
#define CLI_S1_HELP                                                                                \
    "  --s1 grid|march          single scattering from light grids (default): one\n"               \
    "                           transmittance sweep per light direction, then a lookup per\n"      \
    "                           point; or by the exact march to every light (the oracle)\n"        \
    "  --s1-oversample F        light-grid samples per smallest voxel length (default: the\n"      \
    "                           quality's, 1 at low and medium, 2 at high and ultra)\n"

/* --max-memory SIZE|none (vdbs_memory_parse): *bytes 0 when not given (the default limit),
 * -1 for none. */
vdbs_status cli_max_memory(const cli_args *args, int64_t *bytes, vdbs_error *err);

#define CLI_MAX_MEMORY_HELP                                                                        \
    "  --max-memory SIZE        refuse, before the large allocations, work estimated to need\n"    \
    "                           more memory than SIZE (512M, 8G, 8GiB, bytes; none: no\n"          \
    "                           limit; default: 75% of the machine's or the cgroup's)\n"

/* "memory": the limit, the resident set the estimate starts from, the estimate by part and
 * each stage's peak resident set (bytes), into j. */
void cli_json_memory(struct cJSON *j, int64_t limit, int64_t baseline,
                     const vdbs_memory_estimate *estimate, const char *const stages[],
                     const int64_t peaks[], int stage_count, int per_stage);

/* Prints "vdbscatter CMD: message" on stderr and returns the exit status for status
 * (a vdbs_status or an exit status: 2, VDBS_ERR_INPUT, is a usage error). */
int cli_fail(const char *command, int status, const char *message);

/* Prints a warning line on stderr ("vdbscatter: warning: ..."); user = quiet flag ptr. */
void cli_warn(void *quiet, const char *message);

#endif
