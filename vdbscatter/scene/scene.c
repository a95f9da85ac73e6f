/* The scene in memory: defaults, the pools of env-map and OBJ paths, the grid spec, the
 * density scale, value ranges and the solvers' options by key. Reading and writing scene
 * files is scene_file.c's, above the solvers. */
#include "vdbscatter/scene.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

bool vdbs_grid_spec_split(const char *spec, char name[256], int *index, const char **why)
{
    const char *at = strrchr(spec, '@');
    size_t len = at ? (size_t)(at - spec) : strlen(spec);
    long idx = 0;
    if (len == 0) {
        *why = "empty grid name";
        return false;
    }
    if (len >= 256) {
        *why = "grid name longer than 255 bytes";
        return false;
    }
    if (at) {
        const char *p = at + 1;
        if (!*p) {
            *why = "INDEX missing after '@'";
            return false;
        }
        for (; *p; ++p) {
            if (*p < '0' || *p > '9') {
                *why = "INDEX must be a non-negative integer";
                return false;
            }
            idx = idx * 10 + (*p - '0');
            if (idx > INT_MAX) {
                *why = "INDEX too large";
                return false;
            }
        }
    }
    memcpy(name, spec, len);
    name[len] = '\0';
    *index = (int)idx;
    return true;
}

vdbs_status vdbs_scene_set_grid(vdbs_scene *scene, const char *spec, vdbs_error *err)
{
    const char *why = NULL;
    char name[256];
    int index = 0;
    if (!spec) /* a caller's mistake: the CLI always has a value */
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "scene: grid: no grid name given");
    if (!vdbs_grid_spec_split(spec, name, &index, &why))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "scene: grid \"%.64s\": %s (expected NAME or NAME@INDEX)", spec, why);
    memcpy(scene->grid, name, sizeof name);
    scene->grid_index = index;
    return VDBS_OK;
}

vdbs_status vdbs_scene_set_density_scale(vdbs_scene *scene, const char *what, const char *text,
                                         vdbs_error *err)
{
    int is_auto = text && strncmp(text, "auto:", 5) == 0;
    const char *num = is_auto ? text + 5 : text;
    char *end = NULL;
    errno = 0;
    double v = num ? strtod(num, &end) : NAN;
    if (!num || end == num || *end != '\0' || errno == ERANGE || !isfinite(v) ||
        (is_auto ? !(v > 0.0) : !(v >= 0.0)))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: expected a number >= 0 or auto:TAU with TAU > 0 (the mean "
                              "optical depth through the volume), got '%s'",
                              what, text ? text : "");
    scene->density_scale = is_auto ? scene->density_scale : v;
    scene->density_target_depth = is_auto ? v : 0.0;
    return VDBS_OK;
}

void vdbs_scene_init(vdbs_scene *scene)
{
    memset(scene, 0, sizeof *scene);
    scene->density_scale = 1.0;
    scene->albedo[0] = scene->albedo[1] = scene->albedo[2] = 0.5;
    scene->g = 0.0;
    scene->camera.present = 0;
    scene->camera.up[1] = 1.0;
    scene->camera.fov_deg = 35.0;
    scene->camera.width = 640;
    scene->camera.height = 480;
    snprintf(scene->method, sizeof scene->method, "%s", "svd");
    snprintf(scene->quality, sizeof scene->quality, "%s", "low");
}

/* ---- path pools (env maps, OBJ files) ---- */

/* The path `ref` refers to in a pool of `cap` bytes, or NULL unless it is the start of a
 * NUL-terminated non-empty string of the pool. */
static const char *pool_path_at(const char *pool, size_t cap, int ref)
{
    if (ref < 1 || (size_t)ref > cap)
        return NULL;
    size_t off = (size_t)ref - 1;
    const char *p = pool + off;
    if (!p[0] || (off > 0 && p[-1] != '\0') || !memchr(p, '\0', cap - off))
        return NULL;
    return p;
}

/* The reference of path in a pool of `cap` bytes, added if new; 0 when there is no room. */
static int pool_path_add(char *pool, size_t cap, const char *path)
{
    size_t len = strlen(path), off = 0;
    while (off < cap && pool[off]) {
        const char *p = pool + off;
        const char *end = memchr(p, '\0', cap - off);
        if (!end)
            return 0; /* unterminated: nothing can be appended */
        size_t n = (size_t)(end - p);
        if (n == len && memcmp(p, path, len) == 0)
            return (int)off + 1;
        off += n + 1;
    }
    if (off >= cap || len + 1 > cap - off)
        return 0;
    memcpy(pool + off, path, len + 1);
    return (int)off + 1;
}

static const char *env_path_at(const vdbs_scene *s, int env_map)
{
    return pool_path_at(s->env_paths, sizeof s->env_paths, env_map);
}

static int env_path_add(vdbs_scene *s, const char *path)
{
    return pool_path_add(s->env_paths, sizeof s->env_paths, path);
}

static const char *occluder_path_at(const vdbs_scene *s, int obj_file)
{
    return pool_path_at(s->occluder_paths, sizeof s->occluder_paths, obj_file);
}

const char *vdbs_occluder_obj_file(const vdbs_scene *scene, const vdbs_occluder *occluder)
{
    if (occluder->type != VDBS_OCCLUDER_OBJ)
        return "";
    const char *p = occluder_path_at(scene, occluder->obj_file);
    return p ? p : "";
}

vdbs_status vdbs_occluder_set_obj_file(vdbs_scene *scene, vdbs_occluder *occluder, const char *path,
                                       vdbs_error *err)
{
    if (!path || !path[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT, "scene: occluder OBJ path is empty");
    if (strlen(path) >= VDBS_PATH_MAX)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "scene: occluder OBJ path too long (at most %d bytes)",
                              VDBS_PATH_MAX - 1);
    int ref = pool_path_add(scene->occluder_paths, sizeof scene->occluder_paths, path);
    if (!ref)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "scene: occluder OBJ paths take more than %d bytes together",
                              VDBS_OCCLUDER_PATHS_MAX);
    occluder->obj_file = ref;
    return VDBS_OK;
}

const char *vdbs_light_env_file(const vdbs_scene *scene, const vdbs_light *light)
{
    const char *p = env_path_at(scene, light->env_map);
    return p ? p : "";
}

vdbs_status vdbs_light_set_env_file(vdbs_scene *scene, vdbs_light *light, const char *path,
                                    vdbs_error *err)
{
    if (!path || !path[0]) {
        light->env_map = 0;
        return VDBS_OK;
    }
    if (strlen(path) >= VDBS_PATH_MAX)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "scene: env map path too long (at most %d bytes)", VDBS_PATH_MAX - 1);
    int ref = env_path_add(scene, path);
    if (!ref)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "scene: env map paths take more than %d bytes together",
                              VDBS_ENV_PATHS_MAX);
    light->env_map = ref;
    return VDBS_OK;
}

void vdbs_scene_copy_lights(vdbs_scene *dst, const vdbs_scene *src)
{
    if (dst == src)
        return;
    memcpy(dst->lights, src->lights, sizeof dst->lights);
    dst->light_count = src->light_count;
    memcpy(dst->env_paths, src->env_paths, sizeof dst->env_paths);
}

void vdbs_scene_clear_lights(vdbs_scene *scene)
{
    memset(scene->lights, 0, sizeof scene->lights);
    scene->light_count = 0;
    memset(scene->env_paths, 0, sizeof scene->env_paths);
}

/* ---- solver options ---- */

double vdbs_scene_solver_value(const vdbs_scene *scene, const char *key)
{
    for (int i = 0; i < scene->solver_setting_count; ++i)
        if (strcmp(scene->solver_settings[i].key, key) == 0)
            return scene->solver_settings[i].value;
    return 0.0;
}

vdbs_status vdbs_scene_solver_store(vdbs_scene *scene, const char *key, double value,
                                    vdbs_error *err)
{
    int i = 0;
    while (i < scene->solver_setting_count && strcmp(scene->solver_settings[i].key, key) != 0)
        ++i;
    if (strlen(key) >= sizeof scene->solver_settings[0].key || i == VDBS_MAX_SOLVER_SETTINGS)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "scene: solver.%s: no room for it (at most %d solver options, keys "
                              "under %zu bytes)",
                              key, VDBS_MAX_SOLVER_SETTINGS, sizeof scene->solver_settings[0].key);
    snprintf(scene->solver_settings[i].key, sizeof scene->solver_settings[i].key, "%s", key);
    scene->solver_settings[i].value = value;
    if (i == scene->solver_setting_count)
        ++scene->solver_setting_count;
    return VDBS_OK;
}

/* ---- value ranges ---- */

vdbs_status vdbs_check_colour(const char *what, const double c[3], vdbs_error *err)
{
    if (!(isfinite(c[0]) && isfinite(c[1]) && isfinite(c[2])) || c[0] < 0.0 || c[1] < 0.0 ||
        c[2] < 0.0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: must be finite and >= 0, got [%g, %g, %g]",
                              what, c[0], c[1], c[2]);
    return VDBS_OK;
}

vdbs_status vdbs_check_albedo(const char *what, const double a[3], vdbs_error *err)
{
    for (int i = 0; i < 3; ++i)
        if (!(a[i] >= 0.0 && a[i] <= 1.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "%s: each component must be in [0, 1], got [%g, %g, %g]", what,
                                  a[0], a[1], a[2]);
    return VDBS_OK;
}

vdbs_status vdbs_check_g(const char *what, double g, vdbs_error *err)
{
    if (!(g >= -0.999 && g <= 0.999))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: must be in [-0.999, 0.999], got %g", what,
                              g);
    return VDBS_OK;
}
