/* Scene files: the scene as JSON (docs/design.md "Scene files"), read, checked and written
 * back. Above the solvers, because a scene's solver.* keys are the solver table's options
 * (solver.h); the scene itself (scene.h) sits below everything that reads it. */
#ifndef VDBSCATTER_SCENE_FILE_H
#define VDBSCATTER_SCENE_FILE_H

#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Parses scene JSON. Relative paths are resolved against base_dir (may be NULL).
 * Unknown keys are errors (a typo must not be silently ignored). Every error names
 * the offending key, e.g. "scene: lights[1].direction: expected 3 finite numbers".
 * The scene starts from vdbs_scene_init; keys not given keep those defaults. On error
 * *scene is left untouched. Ranges are checked by vdbs_scene_validate, not here.
 * Per light type: sun {direction (required), irradiance = 1, angular_diameter_deg = 0},
 * point {position (required), intensity = 1}, env {color | file [, scale = 1]}; a camera
 * needs position and target. Colours and albedo take one number or three.
 * Occluders: obj {file (required), translate = 0, scale = 1 (one number or three),
 * rotate_deg = 0}, sphere {center, radius}, box {min, max}, plane {point, normal}, each
 * with albedo = 0.5; fog {sigma_t (required), albedo = 1, box {min, max} (absent: the
 * volume's bounds)}. Unlike the other keys, occluder and fog ranges are checked here too
 * (as in vdbs_scene_validate). OBJ paths are resolved, not opened: vdbs_occluders_check
 * (mesh.h) reads the files. */
vdbs_status vdbs_scene_parse(const char *json_text, const char *base_dir, vdbs_scene *scene,
                             vdbs_error *err);

/* Reads and parses a scene file (base_dir = the file's folder). Errors, including a
 * missing or unreadable file, are VDBS_ERR_INPUT and start with "scene FILE: ". */
vdbs_status vdbs_scene_load(const char *path, vdbs_scene *scene, vdbs_error *err);

/* Serialises the resolved scene as JSON (malloc'd string; free with free(); NULL when
 * out of memory). vdbs_scene_parse of the result with base_dir NULL gives back the same
 * scene, bit for bit (paths are already resolved; an absent camera is not written), up
 * to where in env_paths each map's path lies. */
char *vdbs_scene_to_json(const vdbs_scene *scene);

/* Checks ranges: finite values, density_scale >= 0, albedo in [0,1], g in (-1,1)
 * (|g| <= 0.999), non-zero sun directions (normalised in place), non-negative colours,
 * at least one light, camera fov in (0,180) and positive size. Also: width and height
 * at most 16384, target != position, up not parallel to the view direction, sun
 * angular_diameter_deg in [0,180), env scale >= 0, a known method and quality, the
 * occluders' and fog's ranges (albedo in [0,1], scale > 0, radius > 0, box min < max,
 * non-zero plane normal (normalised in place), fog sigma_t >= 0). Errors
 * name the key path ("scene: volume.g: ..."); on error nothing is normalised. An env
 * light whose env_map is not a path of this scene (a light copied from another scene
 * without its paths) is a VDBS_ERR_INTERNAL error. */
vdbs_status vdbs_scene_validate(vdbs_scene *scene, vdbs_error *err);
/* The same, with no light allowed when lights_optional (a command that checks its input
 * files first and reports a missing light after them, or renders a lit VDB's own). */
vdbs_status vdbs_scene_validate_opt(vdbs_scene *scene, int lights_optional, vdbs_error *err);
/* --method / solver.method and --quality / solver.quality: a name the solver table (or the
 * quality ladder) knows, else VDBS_ERR_INPUT naming `what` (the flag or the key path), the
 * nearest valid name and the list. A bad name leaves the scene unchanged. */
vdbs_status vdbs_scene_set_method(vdbs_scene *scene, const char *what, const char *name,
                                  vdbs_error *err);
vdbs_status vdbs_scene_set_quality(vdbs_scene *scene, const char *what, const char *name,
                                   vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
