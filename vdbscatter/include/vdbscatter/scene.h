/* The scene: medium parameters, lights, camera and solver settings, read from a
 * JSON scene file (docs/design.md "Scene files") and overridden by command-line flags. */
#ifndef VDBSCATTER_SCENE_H
#define VDBSCATTER_SCENE_H

#include <stdbool.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VDBS_MAX_LIGHTS 64
#define VDBS_PATH_MAX 4096
/* Bytes of env-map paths a scene holds, all lights together (each distinct path once):
 * room for two of the longest paths, or many ordinary ones. Keeping paths out of the
 * lights keeps a scene small enough to copy by value (and to mirror from ctypes). */
#define VDBS_ENV_PATHS_MAX (2 * VDBS_PATH_MAX)

typedef enum vdbs_light_type {
    VDBS_LIGHT_SUN = 0,
    VDBS_LIGHT_POINT = 1,
    VDBS_LIGHT_ENV = 2
} vdbs_light_type;

typedef struct vdbs_light {
    vdbs_light_type type;
    double direction[3]; /* sun: unit direction in which the light travels */
    double position[3];  /* point: world position */
    double color[3];     /* sun: irradiance W/m^2; point: intensity W/sr; env: constant radiance */
    double angular_diameter_deg; /* sun; 0 = delta light */
    /* env: lat-long OpenEXR map, as 1 + the byte offset of its resolved path in the
     * scene's env_paths; 0 for a constant env. Read it with vdbs_light_env_file and set
     * it with vdbs_light_set_env_file: it means something only next to its own scene. */
    int env_map;
    double env_scale; /* env: multiplier of the map (1 for a constant env) */
    /* Fields a light type does not use are 0, except color = 1 for an env map. */
} vdbs_light;

/* Solid occluders and a homogeneous fog (docs/design.md "Scene files"): only vdbscatter-view
 * draws them; bake and render accept them and say that they ignore them. */
#define VDBS_MAX_OCCLUDERS 32
/* Bytes of OBJ paths a scene holds, all occluders together (each distinct path once):
 * one path of the longest length, or 32 of 127 bytes. Kept apart from env_paths so that
 * copying lights never moves an occluder's file; one VDBS_PATH_MAX keeps the scene within
 * the 32 KiB it may take (test_scene). */
#define VDBS_OCCLUDER_PATHS_MAX VDBS_PATH_MAX

typedef enum vdbs_occluder_type {
    VDBS_OCCLUDER_OBJ = 0,
    VDBS_OCCLUDER_SPHERE = 1,
    VDBS_OCCLUDER_BOX = 2,
    VDBS_OCCLUDER_PLANE = 3
} vdbs_occluder_type;

typedef struct vdbs_occluder {
    vdbs_occluder_type type;
    /* obj: the Wavefront OBJ file, as 1 + the byte offset of its resolved path in the
     * scene's occluder_paths (read it with vdbs_occluder_obj_file). */
    int obj_file;
    /* obj: p_world = translate + R (scale * p_file), R = Rz Ry Rx of rotate_deg (rotation
     * about X first, then Y, then Z, each counter-clockwise looking down the axis). */
    double translate[3];
    double scale[3]; /* > 0 each; default 1 */
    double rotate_deg[3];
    double center[3]; /* sphere */
    double radius;    /* sphere, > 0 */
    double min[3];    /* box: min < max on every axis */
    double max[3];
    double point[3];  /* plane: a point on it */
    double normal[3]; /* plane: non-zero (normalised by vdbs_scene_validate); the lit side */
    double albedo[3]; /* diffuse reflectance in [0,1]; default 0.5 */
    /* Fields a type does not use are 0 (scale 1 for every type). */
} vdbs_occluder;

/* A homogeneous fog filling a box (the volume's bounds when it has none). */
typedef struct vdbs_scene_fog {
    int present;
    double sigma_t;   /* extinction per world unit, >= 0 */
    double albedo[3]; /* single-scattering albedo in [0,1]; default 1 (scatters, absorbs nothing) */
    double g;         /* Henyey-Greenstein anisotropy in [-0.999, 0.999]; default 0 */
    int has_box;      /* 0: the volume's bounds, resolved by the viewer */
    double box_min[3];
    double box_max[3];
} vdbs_scene_fog;

/* The most sky ordinates a scene may ask for. */
#define VDBS_MAX_SKY_DIRECTIONS 65536

/* One solver option of a scene (solver.h): its scene key and value (a choice's index). */
#define VDBS_MAX_SOLVER_SETTINGS 32
typedef struct vdbs_solver_setting {
    char key[24];
    double value;
} vdbs_solver_setting;

typedef struct vdbs_camera {
    int present;
    double position[3];
    double target[3];
    double up[3];   /* default +Y */
    double fov_deg; /* vertical field of view */
    int width;
    int height;
} vdbs_camera;

typedef struct vdbs_scene {
    char volume_file[VDBS_PATH_MAX]; /* resolved against the scene file's folder; "" if unset */
    char grid[256];                  /* "" = default choice */
    int grid_index;                  /* from "NAME@INDEX" */
    double density_scale;
    /* > 0: --density-scale auto:TAU / "density_scale": "auto:TAU": the bake or render sets
     * density_scale from the volume so that its mean optical depth is TAU (then this is 0). */
    double density_target_depth;
    double albedo[3];
    double g;
    vdbs_light lights[VDBS_MAX_LIGHTS];
    int light_count;
    /* The lights' env-map paths, NUL-terminated one after the other (an empty string
     * ends the list); copy lights between scenes with vdbs_scene_copy_lights. */
    char env_paths[VDBS_ENV_PATHS_MAX];
    vdbs_camera camera;
    char method[32];    /* a solver table name: "svd" (the default), "fld", "pop", "single" */
    char quality[32];   /* "low", "medium", "high", "ultra" */
    int sky_directions; /* sky ordinates K (solver.sky_directions, --sky-directions); 0: the
                           quality's 16 / 64 / 256 / 1024 */
    /* The solvers' own options (solver.h: each entry declares its keys), by scene key;
     * a key not here is 0, its default. Set them through solver.h, read them with
     * vdbs_scene_solver_value. */
    vdbs_solver_setting solver_settings[VDBS_MAX_SOLVER_SETTINGS];
    int solver_setting_count;
    vdbs_occluder occluders[VDBS_MAX_OCCLUDERS];
    int occluder_count;
    /* The occluders' OBJ paths, NUL-terminated one after the other (as env_paths). */
    char occluder_paths[VDBS_OCCLUDER_PATHS_MAX];
    vdbs_scene_fog fog;
} vdbs_scene;

/* Defaults follow Blender Cycles' Principled Volume: density 1, albedo 0.5, g 0;
 * method "svd", quality "low" (the measured best error for the time on general volumes:
 * bench/defaults.md, docs/design.md "Decisions"), no lights, no camera. */
void vdbs_scene_init(vdbs_scene *scene);

/* The value ranges, shared by vdbs_scene_validate and the command line's flags so that an
 * error names where the value came from (`what`: "scene: volume.g", "--g"): a colour is
 * finite and >= 0, an albedo in [0, 1], g in [-0.999, 0.999]. VDBS_ERR_INPUT otherwise. */
vdbs_status vdbs_check_colour(const char *what, const double c[3], vdbs_error *err);
vdbs_status vdbs_check_albedo(const char *what, const double a[3], vdbs_error *err);
vdbs_status vdbs_check_g(const char *what, double g, vdbs_error *err);
#define VDBS_NO_LIGHT_MESSAGE "no light at all (add a sun, point or env light)"

/* Parses a density scale: a number >= 0, or "auto:TAU" (TAU > 0, a mean optical depth)
 * into scene->density_target_depth. Errors name `what`. */
vdbs_status vdbs_scene_set_density_scale(vdbs_scene *scene, const char *what, const char *text,
                                         vdbs_error *err);

/* Splits "NAME" or "NAME@INDEX" (at the last '@') into name and *index; on failure returns
 * false and *why says what is wrong. */
bool vdbs_grid_spec_split(const char *spec, char name[256], int *index, const char **why);

/* Parses "NAME" or "NAME@INDEX" (split at the last '@'; INDEX decimal digits) into
 * scene->grid / scene->grid_index. A bad spec leaves the scene unchanged. */
vdbs_status vdbs_scene_set_grid(vdbs_scene *scene, const char *spec, vdbs_error *err);

/* A solver option's value in the scene (solver.h), 0 (the default) when unset. */
double vdbs_scene_solver_value(const vdbs_scene *scene, const char *key);
/* Stores a solver option's value under its scene key, replacing one already there; no range
 * check (solver.h's setters check). Errors (VDBS_ERR_INPUT): a key too long, or no room. */
vdbs_status vdbs_scene_solver_store(vdbs_scene *scene, const char *key, double value,
                                    vdbs_error *err);

/* The resolved env-map path of an env light of `scene`: "" for a constant env, and also
 * for an env_map that is not a path of this scene (vdbs_scene_validate reports that). */
const char *vdbs_light_env_file(const vdbs_scene *scene, const vdbs_light *light);

/* Points `light` (one of scene's lights, or one about to be stored there) at `path`,
 * adding the path to scene->env_paths unless it is there already; NULL or "" makes it a
 * constant env. Errors (VDBS_ERR_INPUT, light unchanged): a path of VDBS_PATH_MAX bytes
 * or more, or no room left in env_paths. */
vdbs_status vdbs_light_set_env_file(vdbs_scene *scene, vdbs_light *light, const char *path,
                                    vdbs_error *err);

/* Replaces dst's lights by src's, with their env-map paths (a plain copy of the lights
 * array would leave their env_map pointing into dst's paths). */
void vdbs_scene_copy_lights(vdbs_scene *dst, const vdbs_scene *src);

/* Removes every light and every env-map path. */
void vdbs_scene_clear_lights(vdbs_scene *scene);

/* The resolved OBJ path of an obj occluder of `scene`; "" for another type, and also for
 * an obj_file that is not a path of this scene (vdbs_scene_validate reports that). */
const char *vdbs_occluder_obj_file(const vdbs_scene *scene, const vdbs_occluder *occluder);

/* Points `occluder` (one of scene's, or one about to be stored there) at the OBJ file
 * `path`, adding it to scene->occluder_paths unless it is there already. Errors
 * (VDBS_ERR_INPUT, occluder unchanged): an empty path, one of VDBS_PATH_MAX bytes or more,
 * or no room left in occluder_paths. */
vdbs_status vdbs_occluder_set_obj_file(vdbs_scene *scene, vdbs_occluder *occluder, const char *path,
                                       vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
