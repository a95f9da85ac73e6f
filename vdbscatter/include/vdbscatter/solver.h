/* Solvers as a table. Each bake method is one entry, defined in the solver's own file, that
 * carries its whole face: name and summary, options (flag, scene key, type, range, default
 * per quality), its report block, its optional state (--keep-state / --warm-start), its run
 * function and a cost hint. The command line's flags, the scene's solver.* keys, bake --help,
 * the JSON report and the lit VDB's metadata all come from the entry. Adding a solver is its
 * own files plus one line of the table in solver.c (or vdbs_solver_register, for a solver
 * that lives outside the library). */
#ifndef VDBSCATTER_SOLVER_H
#define VDBSCATTER_SOLVER_H

#include <stddef.h>

#include "vdbscatter/quality.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/solve.h"
#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

struct cJSON;

typedef enum vdbs_option_kind {
    VDBS_OPTION_INT = 0, /* an integer in [min, max] */
    VDBS_OPTION_NUMBER,  /* a number in (min, max) on the command line; in a scene also 0 */
    VDBS_OPTION_CHOICE   /* one of `choices`, stored as its index; index 0 is the default */
} vdbs_option_kind;

/* One number of a solver's report block, read from its stats by offset. */
typedef enum vdbs_report_kind {
    VDBS_REPORT_INT = 0, /* int */
    VDBS_REPORT_INT64,   /* int64_t / long long */
    VDBS_REPORT_DOUBLE,  /* double */
    VDBS_REPORT_BOOL,    /* int, written true / false */
    VDBS_REPORT_ON_OFF,  /* int, written "on" / "off" */
    VDBS_REPORT_SECONDS  /* double, a stage time: into the report's "seconds" */
} vdbs_report_kind;

typedef struct vdbs_report_field {
    const char *key; /* in the solver's block; a stage time's key is prefixed by the solver's
                        name in "seconds" ("svd_solve") */
    vdbs_report_kind kind;
    size_t offset; /* offsetof(the solver's stats, the field) */
} vdbs_report_field;

/* One option of a solver. Unset, an option is 0 in the scene (vdbs_scene_solver_value), which
 * means its default: preset[quality], or the solver's own rule where preset is all 0. */
typedef struct vdbs_solver_option {
    const char *key;  /* solver.KEY in a scene file: "pop_res"; unique over all solvers */
    const char *flag; /* the command line's: "--pop-res" */
    vdbs_option_kind kind;
    const char *syntax;         /* the value in --help ("N", "LAW", "on|off"); NULL: a flag without
                                   a value that selects choice 1 (--pop-importance) */
    double min, max;            /* INT, NUMBER */
    const char *const *choices; /* CHOICE: the names, NULL-terminated */
    const char *noun;           /* CHOICE: what a value is, in errors ("decay"); NULL: "value" */
    const char *even;           /* INT: non-NULL: the count must be even, because of this */
    const char *help;           /* --help text after the flag; '\n' starts an indented line */
    const char *report_key;     /* non-NULL: the report block shows the value under this key */
    double preset[VDBS_QUALITY_COUNT]; /* the default per quality, low to ultra; all 0: the
                                          solver's own rule (the help says which) */
} vdbs_solver_option;

/* What a solver keeps between bakes (--keep-state writes it into the lit VDB, --warm-start
 * reads it back). The bake hands `state` to the run as vdbs_solve.keep / .warm. */
typedef struct vdbs_solver_state {
    /* A new, empty state for --keep-state (the run fills it); NULL when out of memory. */
    void *(*create)(void);
    /* --warm-start: the state a --keep-state bake wrote into `path`, at the volume's output
     * voxels, checked against the scene's options. VDBS_ERR_INPUT naming --warm-start when
     * the file holds none or it does not fit. */
    vdbs_status (*read)(const char *path, const vdbs_volume *volume, const vdbs_scene *scene,
                        void **state, vdbs_error *err);
    /* The grids and file metadata that --keep-state writes, pointing into the state. Each
     * returns how many it filled, at most `max`; grids with NULL returns how many it has. */
    int (*grids)(const void *state, vdbio_vec3_grid *grids, int max);
    int (*meta)(const void *state, vdbio_meta *meta, int max);
    /* The arrays of 3 floats per output voxel that --keep-state fills in a bake of `scene`
     * (`warm`: its --warm-start's state, or NULL), for the bake's memory estimate. */
    int (*arrays)(const vdbs_scene *scene, const void *warm);
    void (*destroy)(void *state); /* NULL is fine */
    /* 1: a frame sequence keeps and warm-starts this state only with --keep-state (its grids
     * are large for what they save); 0: by default. */
    int sequence_on_request;
} vdbs_solver_state;

/* The grids of a state held as `count` arrays (3 floats per output voxel each), named PREFIX
 * then the index in 4 digits (svd_m0000 ...): the body of a state's `grids`. `names` is the
 * state's own, made on the first call (freed by the state). As `grids` returns: the count for
 * NULL grids, else how many filled, -1 out of memory. */
int vdbs_solver_state_grids(const char *prefix, int count, float *const *values, char (**names)[24],
                            vdbio_vec3_grid *grids, int max);

/* The largest report block (stats) any solver keeps: the bake report holds it by value. */
#define VDBS_SOLVER_STATS_MAX 1024

typedef struct vdbs_solver {
    const char *name;    /* --method, solver.method */
    const char *summary; /* one line for --help */
    int writes_ms;       /* 0: ms and ms_l1 stay 0 (the bake then shares one zero array) */
    const vdbs_solver_option *options;
    int option_count;
    /* Runs the solve; fills stats (stats_size bytes, zeroed by the caller) when it has any. */
    vdbs_status (*run)(const vdbs_solve *solve, void *stats, vdbs_error *err);
    size_t stats_size; /* at most VDBS_SOLVER_STATS_MAX */
    /* Checks between options that one option's range cannot say (terms <= directions);
     * errors name `prefix` + "solver.KEY". NULL: none. */
    vdbs_status (*validate)(const vdbs_scene *scene, const char *prefix, vdbs_error *err);
    /* The scene as this solver will bake it (its camera and lights set): the refusals it can
     * say before the volume loads, so that bad input costs no load and prints no progress
     * (VDBS_ERR_INPUT). NULL: none. */
    vdbs_status (*check)(const vdbs_scene *scene, vdbs_error *err);
    /* The report block: these fields of the stats (vdbs_solver_report_json), then the
     * options that have a report_key. */
    const vdbs_report_field *report;
    int report_count;
    /* The same in one line of text for the bake's summary ("D 32, N 5, 41 iterations");
     * NULL: none. */
    void (*report_text)(const void *stats, char *text, size_t size);
    const vdbs_solver_state *state; /* NULL: keeps no state */
    /* The solve's own arrays, in bytes for a bake of `scene` on `voxels` output voxels: those
     * that follow the voxels, and those its own options size (the illumination network's
     * particles and directions; the coarse grids, bounded by the resolution, aside). The bake's
     * memory estimate. NULL: none beyond the S1 pass's. */
    int64_t (*solve_bytes)(const vdbs_scene *scene, size_t voxels);
    /* The solver's flags that lower solve_bytes beyond what the voxels need ("--inet-particles"),
     * named when the estimate refuses a bake; NULL: none. */
    const char *solve_bytes_flags;
    /* Cost hint for planning: the solve's seconds per million output voxels on the C path
     * at each quality, measured on the bundled cloud (bench/defaults.md); the same
     * order of magnitude on other scenes, no more. */
    double cost[VDBS_QUALITY_COUNT];
    /* The part of the solve's seconds that does not follow the voxels, at each quality, from
     * the same bench at two volume sizes (0 for a solver whose work is all per voxel; the
     * illumination network's sweeps follow its particles and directions). */
    double cost_fixed[VDBS_QUALITY_COUNT];
    /* The sky quadrature of S1 at each quality; 0: the quality's (quality.h). A method whose
     * error rises with a finer sky (its bias no longer cancels) stops its ladder here. */
    int sky_directions[VDBS_QUALITY_COUNT];
    /* Where the ladder stops ("medium"): a higher quality bakes exactly as this one (S1 and
     * the solver's presets), because beyond it the method's bias floor, not its settings,
     * sets the error. NULL: the whole ladder. */
    const char *ladder_stop;
} vdbs_solver;

/* The sky directions of a bake: the scene's when set, else the solver's at the quality,
 * else the quality's. */
int vdbs_solver_sky_directions(const vdbs_solver *solver, const vdbs_scene *scene,
                               const vdbs_quality *quality);

/* The quality whose settings the solver bakes at `quality`: the same, or its ladder's stop
 * below it. */
const vdbs_quality *vdbs_solver_quality(const vdbs_solver *solver, const vdbs_quality *quality);

/* The solver of a method name, or NULL if none is implemented under that name. */
const vdbs_solver *vdbs_solver_find(const char *name);
/* The solver at `index` in table order (registered ones last), or NULL past the end. */
const vdbs_solver *vdbs_solver_at(int index);
/* "single, pop, ...": the names for messages. */
void vdbs_solver_names(char *buf, size_t size);

/* Adds a solver that lives outside the library (a test's, a plugin's) after the table's, for
 * the life of the process; not thread-safe: register before any bake. Errors
 * (VDBS_ERR_INTERNAL): a name, scene key or flag that is taken, stats over the maximum, or
 * no room (8 at most). */
vdbs_status vdbs_solver_register(const vdbs_solver *solver, vdbs_error *err);

/* The option of a scene key or a flag over every solver, with its solver; NULL if none. */
const vdbs_solver_option *vdbs_solver_option_by_key(const char *key, const vdbs_solver **solver);
const vdbs_solver_option *vdbs_solver_option_by_flag(const char *flag, const vdbs_solver **solver);

/* The value an option has in a scene: as set, else its preset at `quality` (0 where the
 * solver has its own rule). */
double vdbs_solver_option_value(const vdbs_scene *scene, const vdbs_solver_option *option,
                                const vdbs_quality *quality);
/* Sets an option from a number (a scene file's; choices by index), checking its range;
 * errors name `what` ("scene: solver.pop_res"). */
vdbs_status vdbs_solver_option_set(vdbs_scene *scene, const vdbs_solver_option *option,
                                   const char *what, double value, vdbs_error *err);
/* The same by scene key (choices by index): for programs that set options directly. Errors
 * name "solver.KEY"; a key no solver has is VDBS_ERR_INPUT. */
vdbs_status vdbs_solver_set(vdbs_scene *scene, const char *key, double value, vdbs_error *err);
/* Sets a CHOICE option by name; errors name `what`. */
vdbs_status vdbs_solver_option_choose(vdbs_scene *scene, const vdbs_solver_option *option,
                                      const char *what, const char *name, vdbs_error *err);
/* The name of a CHOICE option's value in a scene. */
const char *vdbs_solver_option_choice(const vdbs_scene *scene, const vdbs_solver_option *option);
/* Checks every solver option a scene sets against its range, and each solver's validate
 * (errors name prefix + "solver.KEY"); VDBS_ERR_INPUT for a key no solver has. */
vdbs_status vdbs_solver_options_check(const vdbs_scene *scene, const char *prefix, vdbs_error *err);
/* The solver's report block from its stats: stage times into `seconds`, the rest and the
 * options with a report_key into `block` (the report's object named after the solver); no
 * block for a solver without report fields. */
void vdbs_solver_report_json(const vdbs_solver *solver, const vdbs_scene *scene, const void *stats,
                             struct cJSON *seconds, struct cJSON *report);
/* Writes an option's --help lines ("  --pop-res N     POP: ...") into buf. */
void vdbs_solver_option_help(const vdbs_solver_option *option, char *buf, size_t size);

#ifdef __cplusplus
}
#endif

#endif
