/* Scene files: strict JSON parsing (every unknown key, wrong type or non-finite number is
 * an error naming its key path), range validation, and serialisation that round-trips. The
 * solver.* keys are the solver table's options (solver.h). */
#include "vdbscatter/scene_file.h"

#include "vdbscatter/solver.h"

#include "vdbscatter/suggest.h"
#include "vdbscatter/readfile.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <limits.h>
#include <locale.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PATH_LEN 160
#define SCENE_FILE_MAX (64L * 1024 * 1024)

typedef struct parse_ctx {
    const char *prefix; /* "scene" or "scene FILE" */
    const char *base_dir;
    vdbs_error *err;
} parse_ctx;

/* Formats "PREFIX: PATH: message" (or "PREFIX: message" at the top level). */
static vdbs_status fail(const parse_ctx *ctx, const char *path, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static vdbs_status fail(const parse_ctx *ctx, const char *path, const char *fmt, ...)
{
    char msg[VDBS_ERROR_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (path && path[0])
        return vdbs_error_set(ctx->err, VDBS_ERR_INPUT, "%s: %s: %s", ctx->prefix, path, msg);
    return vdbs_error_set(ctx->err, VDBS_ERR_INPUT, "%s: %s", ctx->prefix, msg);
}

/* Key paths are short (our key names, indices below VDBS_MAX_LIGHTS); truncation could
 * only shorten a message. vsnprintf also keeps gcc's truncation analysis quiet. */
static void fmt_path(char out[PATH_LEN], const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void fmt_path(char out[PATH_LEN], const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out, PATH_LEN, fmt, ap);
    va_end(ap);
}

static void join_path(char *out, const char *parent, const char *key)
{
    if (parent[0])
        fmt_path(out, "%s.%s", parent, key);
    else
        fmt_path(out, "%s", key);
}

static const char *type_name(const cJSON *item)
{
    if (cJSON_IsString(item))
        return "a string";
    if (cJSON_IsBool(item))
        return "a boolean";
    if (cJSON_IsNull(item))
        return "null";
    if (cJSON_IsArray(item))
        return "an array";
    if (cJSON_IsObject(item))
        return "an object";
    if (cJSON_IsNumber(item))
        return "a number";
    return "an invalid value";
}

static bool in_list(const char *s, const char *const *list)
{
    for (; *list; ++list)
        if (strcmp(s, *list) == 0)
            return true;
    return false;
}

/* Rejects keys outside `allowed` and duplicate keys (cJSON keeps both copies, and a
 * silently ignored second value is as bad as a typo). */
static vdbs_status check_keys(const parse_ctx *ctx, const cJSON *obj, const char *path,
                              const char *const *allowed, const char *hint)
{
    for (const cJSON *c = obj->child; c; c = c->next) {
        if (!in_list(c->string, allowed)) {
            char mean[96], names[320];
            vdbs_suggest_hint(c->string, allowed, mean, sizeof mean);
            vdbs_join_names(allowed, names, sizeof names);
            if (hint)
                return fail(ctx, path, "unknown key \"%.64s\"%s%s", c->string, mean, hint);
            return fail(ctx, path, "unknown key \"%.64s\"%s (valid keys: %s)", c->string, mean,
                        names);
        }
        for (const cJSON *d = obj->child; d != c; d = d->next)
            if (strcmp(d->string, c->string) == 0)
                return fail(ctx, path, "duplicate key \"%.64s\"", c->string);
    }
    return VDBS_OK;
}

static vdbs_status expect_object(const parse_ctx *ctx, const cJSON *item, const char *path)
{
    if (!cJSON_IsObject(item))
        return fail(ctx, path, "expected an object, got %s", type_name(item));
    return VDBS_OK;
}

static vdbs_status number_value(const parse_ctx *ctx, const cJSON *item, const char *path,
                                double *out)
{
    if (!cJSON_IsNumber(item))
        return fail(ctx, path, "expected a number, got %s", type_name(item));
    /* JSON has no NaN/Inf literals; a non-finite value comes from an overflowing literal. */
    if (!isfinite(item->valuedouble))
        return fail(ctx, path, "expected a finite number (the value overflows a double)");
    *out = item->valuedouble;
    return VDBS_OK;
}

/* Optional number: leaves *out untouched when the key is absent. */
static vdbs_status get_number(const parse_ctx *ctx, const cJSON *obj, const char *parent,
                              const char *key, double *out)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, key);
    char path[PATH_LEN];
    if (!item)
        return VDBS_OK;
    join_path(path, parent, key);
    return number_value(ctx, item, path, out);
}

static vdbs_status get_int(const parse_ctx *ctx, const cJSON *obj, const char *parent,
                           const char *key, int *out)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, key);
    char path[PATH_LEN];
    double v = 0.0;
    vdbs_status st;
    if (!item)
        return VDBS_OK;
    join_path(path, parent, key);
    if ((st = number_value(ctx, item, path, &v)) != VDBS_OK)
        return st;
    if (v != floor(v) || v < INT_MIN || v > INT_MAX)
        return fail(ctx, path, "expected an integer, got %.17g", v);
    *out = (int)v;
    return VDBS_OK;
}

/* An integer key that, when present, must lie in lo..hi (absent keeps *out: the default). */
static vdbs_status get_int_in(const parse_ctx *ctx, const cJSON *obj, const char *parent,
                              const char *key, int lo, int hi, int *out)
{
    if (!cJSON_GetObjectItemCaseSensitive(obj, key))
        return VDBS_OK;
    int v = 0;
    vdbs_status st = get_int(ctx, obj, parent, key, &v);
    if (st != VDBS_OK)
        return st;
    if (v < lo || v > hi) {
        char path[PATH_LEN];
        join_path(path, parent, key);
        return fail(ctx, path, "must be in %d..%d, got %d", lo, hi, v);
    }
    *out = v;
    return VDBS_OK;
}

/* A 3-vector; with allow_scalar a single number stands for all three components
 * (colours and albedo). */
static vdbs_status get_vec3(const parse_ctx *ctx, const cJSON *obj, const char *parent,
                            const char *key, bool allow_scalar, double out[3])
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, key);
    const char *want = allow_scalar ? "a number or an array of 3 numbers" : "an array of 3 numbers";
    char path[PATH_LEN];
    double v[3] = {0.0, 0.0, 0.0};
    vdbs_status st;
    if (!item)
        return VDBS_OK;
    join_path(path, parent, key);
    if (allow_scalar && cJSON_IsNumber(item)) {
        if ((st = number_value(ctx, item, path, &v[0])) != VDBS_OK)
            return st;
        out[0] = out[1] = out[2] = v[0];
        return VDBS_OK;
    }
    if (!cJSON_IsArray(item))
        return fail(ctx, path, "expected %s, got %s", want, type_name(item));
    if (cJSON_GetArraySize(item) != 3)
        return fail(ctx, path, "expected %s, got an array of %d elements", want,
                    cJSON_GetArraySize(item));
    int i = 0;
    for (const cJSON *c = item->child; c; c = c->next, ++i) {
        char elem[PATH_LEN];
        fmt_path(elem, "%s[%d]", path, i);
        if ((st = number_value(ctx, c, elem, &v[i])) != VDBS_OK)
            return st;
    }
    memcpy(out, v, sizeof v);
    return VDBS_OK;
}

/* Optional non-empty string of fewer than cap bytes; *found tells whether it was given. */
static vdbs_status get_string(const parse_ctx *ctx, const cJSON *obj, const char *parent,
                              const char *key, char *out, size_t cap, bool *found)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, key);
    char path[PATH_LEN];
    *found = false;
    if (!item)
        return VDBS_OK;
    join_path(path, parent, key);
    if (!cJSON_IsString(item))
        return fail(ctx, path, "expected a string, got %s", type_name(item));
    size_t len = strlen(item->valuestring);
    if (len == 0)
        return fail(ctx, path, "expected a non-empty string");
    if (len >= cap)
        return fail(ctx, path, "string too long (%zu bytes, at most %zu)", len, cap - 1);
    memcpy(out, item->valuestring, len + 1);
    *found = true;
    return VDBS_OK;
}

/* A file path from the scene, resolved against the scene file's folder unless absolute. */
static vdbs_status get_path(const parse_ctx *ctx, const cJSON *obj, const char *parent,
                            const char *key, char out[VDBS_PATH_MAX], bool *found)
{
    char raw[VDBS_PATH_MAX];
    char path[PATH_LEN];
    vdbs_status st = get_string(ctx, obj, parent, key, raw, sizeof raw, found);
    if (st != VDBS_OK || !*found)
        return st;
    join_path(path, parent, key);
    const char *base = ctx->base_dir;
    int n;
    if (raw[0] == '/' || !base || !base[0])
        n = snprintf(out, VDBS_PATH_MAX, "%s", raw);
    else if (base[strlen(base) - 1] == '/')
        n = snprintf(out, VDBS_PATH_MAX, "%s%s", base, raw);
    else
        n = snprintf(out, VDBS_PATH_MAX, "%s/%s", base, raw);
    if (n < 0 || n >= VDBS_PATH_MAX)
        return fail(ctx, path, "resolved path too long (at most %d bytes)", VDBS_PATH_MAX - 1);
    return VDBS_OK;
}

/* OK when value is one of names, else an error naming `what` (a flag or a key path) with
 * the nearest valid name and the whole list. */
static vdbs_status check_name(const char *what, const char *kind, const char *const *names,
                              const char *value, vdbs_error *err)
{
    if (value && in_list(value, names))
        return VDBS_OK;
    char mean[96], list[256];
    vdbs_suggest_hint(value ? value : "", names, mean, sizeof mean);
    vdbs_join_names(names, list, sizeof list);
    return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: unknown %s \"%.64s\"%s (expected one of: %s)",
                          what, kind, value ? value : "", mean, list);
}

/* Methods and qualities are checked against solver.c's tables, the one list of each. */
#define MAX_NAMES 16

static vdbs_status check_method(const char *what, const char *name, vdbs_error *err)
{
    const char *names[MAX_NAMES + 1];
    int n = 0;
    for (const vdbs_solver *solver; n < MAX_NAMES && (solver = vdbs_solver_at(n)) != NULL; ++n)
        names[n] = solver->name;
    names[n] = NULL;
    return check_name(what, "method", names, name, err);
}

static vdbs_status check_quality(const char *what, const char *name, vdbs_error *err)
{
    int count = 0, n = 0;
    const vdbs_quality *qualities = vdbs_quality_list(&count);
    const char *names[MAX_NAMES + 1];
    for (; n < count && n < MAX_NAMES; ++n)
        names[n] = qualities[n].name;
    names[n] = NULL;
    return check_name(what, "quality", names, name, err);
}

vdbs_status vdbs_scene_set_method(vdbs_scene *scene, const char *what, const char *name,
                                  vdbs_error *err)
{
    vdbs_status st = check_method(what, name, err);
    if (st == VDBS_OK)
        snprintf(scene->method, sizeof scene->method, "%s", name);
    return st;
}

vdbs_status vdbs_scene_set_quality(vdbs_scene *scene, const char *what, const char *name,
                                   vdbs_error *err)
{
    vdbs_status st = check_quality(what, name, err);
    if (st == VDBS_OK)
        snprintf(scene->quality, sizeof scene->quality, "%s", name);
    return st;
}

/* volume.density_scale: a number, or the string "auto:TAU". */
static vdbs_status get_density_scale(const parse_ctx *ctx, const cJSON *vol, vdbs_scene *s)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(vol, "density_scale");
    if (!cJSON_IsString(item))
        return get_number(ctx, vol, "volume", "density_scale", &s->density_scale);
    char what[PATH_LEN];
    fmt_path(what, "%s: volume.density_scale", ctx->prefix);
    return vdbs_scene_set_density_scale(s, what, item->valuestring, ctx->err);
}

static vdbs_status parse_volume(const parse_ctx *ctx, const cJSON *vol, vdbs_scene *s)
{
    static const char *const keys[] = {"file", "grid", "density_scale", "albedo", "g", NULL};
    vdbs_status st;
    bool found = false;
    char grid[VDBS_PATH_MAX];
    if ((st = expect_object(ctx, vol, "volume")) != VDBS_OK ||
        (st = check_keys(ctx, vol, "volume", keys, NULL)) != VDBS_OK ||
        (st = get_path(ctx, vol, "volume", "file", s->volume_file, &found)) != VDBS_OK ||
        (st = get_density_scale(ctx, vol, s)) != VDBS_OK ||
        (st = get_vec3(ctx, vol, "volume", "albedo", true, s->albedo)) != VDBS_OK ||
        (st = get_number(ctx, vol, "volume", "g", &s->g)) != VDBS_OK ||
        (st = get_string(ctx, vol, "volume", "grid", grid, sizeof grid, &found)) != VDBS_OK)
        return st;
    if (found) {
        const char *why = NULL;
        if (!vdbs_grid_spec_split(grid, s->grid, &s->grid_index, &why))
            return fail(ctx, "volume.grid", "\"%.64s\": %s (expected NAME or NAME@INDEX)", grid,
                        why);
    }
    return VDBS_OK;
}

/* Parses one light into l, a light of s (whose env_paths receive a map's path). */
static vdbs_status parse_light(const parse_ctx *ctx, const cJSON *obj, const char *path,
                               vdbs_scene *s, vdbs_light *l)
{
    static const char *const sun_keys[] = {"type", "direction", "irradiance",
                                           "angular_diameter_deg", NULL};
    static const char *const point_keys[] = {"type", "position", "intensity", NULL};
    static const char *const env_keys[] = {"type", "file", "scale", "color", NULL};
    vdbs_status st;
    const cJSON *type;
    char tpath[PATH_LEN];

    if ((st = expect_object(ctx, obj, path)) != VDBS_OK)
        return st;
    type = cJSON_GetObjectItemCaseSensitive(obj, "type");
    join_path(tpath, path, "type");
    if (!type)
        return fail(ctx, path, "missing \"type\" (sun, point or env)");
    if (!cJSON_IsString(type))
        return fail(ctx, tpath, "expected a string, got %s", type_name(type));

    memset(l, 0, sizeof *l);
    l->color[0] = l->color[1] = l->color[2] = 1.0;
    l->env_scale = 1.0;
    if (strcmp(type->valuestring, "sun") == 0) {
        l->type = VDBS_LIGHT_SUN;
        if ((st = check_keys(ctx, obj, path, sun_keys,
                             " (a sun takes type, direction, irradiance, "
                             "angular_diameter_deg)")) != VDBS_OK)
            return st;
        if (!cJSON_GetObjectItemCaseSensitive(obj, "direction"))
            return fail(ctx, path, "missing \"direction\" (the direction the light travels)");
        if ((st = get_vec3(ctx, obj, path, "direction", false, l->direction)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "irradiance", true, l->color)) != VDBS_OK ||
            (st = get_number(ctx, obj, path, "angular_diameter_deg", &l->angular_diameter_deg)) !=
                VDBS_OK)
            return st;
    } else if (strcmp(type->valuestring, "point") == 0) {
        l->type = VDBS_LIGHT_POINT;
        if ((st = check_keys(ctx, obj, path, point_keys,
                             " (a point light takes type, position, intensity)")) != VDBS_OK)
            return st;
        if (!cJSON_GetObjectItemCaseSensitive(obj, "position"))
            return fail(ctx, path, "missing \"position\"");
        if ((st = get_vec3(ctx, obj, path, "position", false, l->position)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "intensity", true, l->color)) != VDBS_OK)
            return st;
    } else if (strcmp(type->valuestring, "env") == 0) {
        bool has_file = false;
        char file[VDBS_PATH_MAX];
        l->type = VDBS_LIGHT_ENV;
        if ((st = check_keys(ctx, obj, path, env_keys,
                             " (an env light takes type, color, or file and scale)")) != VDBS_OK)
            return st;
        bool has_color = cJSON_GetObjectItemCaseSensitive(obj, "color") != NULL;
        bool has_scale = cJSON_GetObjectItemCaseSensitive(obj, "scale") != NULL;
        if ((st = get_path(ctx, obj, path, "file", file, &has_file)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "color", true, l->color)) != VDBS_OK ||
            (st = get_number(ctx, obj, path, "scale", &l->env_scale)) != VDBS_OK)
            return st;
        /* A map and a constant together would be ambiguous (sum? tint?): refuse it. */
        if (has_file && has_color)
            return fail(ctx, path, "give either \"file\" or \"color\", not both");
        if (!has_file && !has_color)
            return fail(ctx, path, "an env light needs \"file\" or \"color\"");
        if (has_scale && !has_file)
            return fail(ctx, path, "\"scale\" applies to an env \"file\" only");
        if (has_file && vdbs_light_set_env_file(s, l, file, NULL) != VDBS_OK) {
            char fpath[PATH_LEN];
            join_path(fpath, path, "file");
            return fail(ctx, fpath, "the env map paths of a scene take at most %d bytes together",
                        VDBS_ENV_PATHS_MAX);
        }
    } else {
        return fail(ctx, tpath, "unknown light type \"%.64s\" (expected sun, point or env)",
                    type->valuestring);
    }
    return VDBS_OK;
}

static vdbs_status parse_lights(const parse_ctx *ctx, const cJSON *arr, vdbs_scene *s)
{
    vdbs_status st;
    int n;
    if (!cJSON_IsArray(arr))
        return fail(ctx, "lights", "expected an array, got %s", type_name(arr));
    n = cJSON_GetArraySize(arr);
    if (n > VDBS_MAX_LIGHTS)
        return fail(ctx, "lights", "%d lights, at most %d are supported", n, VDBS_MAX_LIGHTS);
    int i = 0;
    for (const cJSON *c = arr->child; c; c = c->next, ++i) {
        char path[PATH_LEN];
        fmt_path(path, "lights[%d]", i);
        if ((st = parse_light(ctx, c, path, s, &s->lights[i])) != VDBS_OK)
            return st;
    }
    s->light_count = n;
    return VDBS_OK;
}

static vdbs_status parse_camera(const parse_ctx *ctx, const cJSON *cam, vdbs_scene *s)
{
    static const char *const keys[] = {"position", "target", "up", "fov_deg",
                                       "width",    "height", NULL};
    vdbs_camera *c = &s->camera;
    vdbs_status st;
    if ((st = expect_object(ctx, cam, "camera")) != VDBS_OK ||
        (st = check_keys(ctx, cam, "camera", keys, NULL)) != VDBS_OK)
        return st;
    if (!cJSON_GetObjectItemCaseSensitive(cam, "position"))
        return fail(ctx, "camera", "missing \"position\"");
    if (!cJSON_GetObjectItemCaseSensitive(cam, "target"))
        return fail(ctx, "camera", "missing \"target\"");
    if ((st = get_vec3(ctx, cam, "camera", "position", false, c->position)) != VDBS_OK ||
        (st = get_vec3(ctx, cam, "camera", "target", false, c->target)) != VDBS_OK ||
        (st = get_vec3(ctx, cam, "camera", "up", false, c->up)) != VDBS_OK ||
        (st = get_number(ctx, cam, "camera", "fov_deg", &c->fov_deg)) != VDBS_OK ||
        (st = get_int(ctx, cam, "camera", "width", &c->width)) != VDBS_OK ||
        (st = get_int(ctx, cam, "camera", "height", &c->height)) != VDBS_OK)
        return st;
    c->present = 1;
    return VDBS_OK;
}

/* The most solver.* keys: method, quality, sky_directions and every solver's options. */
#define SOLVER_KEYS_MAX 128

/* One solver option from its key in the solver object (absent: unchanged). */
static vdbs_status parse_solver_option(const parse_ctx *ctx, const cJSON *sol,
                                       const vdbs_solver_option *o, vdbs_scene *s)
{
    if (!cJSON_GetObjectItemCaseSensitive(sol, o->key))
        return VDBS_OK;
    char path[PATH_LEN], what[PATH_LEN];
    join_path(path, "solver", o->key);
    fmt_path(what, "%s: %s", ctx->prefix, path);
    vdbs_status st;
    if (o->kind == VDBS_OPTION_CHOICE) {
        char value[32] = "";
        bool found = false;
        if ((st = get_string(ctx, sol, "solver", o->key, value, sizeof value, &found)) != VDBS_OK)
            return st;
        return vdbs_solver_option_choose(s, o, what, value, ctx->err);
    }
    if (o->kind == VDBS_OPTION_NUMBER) { /* the range (0 allowed: the default) is validate's */
        double x = 0.0;
        if ((st = get_number(ctx, sol, "solver", o->key, &x)) != VDBS_OK)
            return st;
        return vdbs_scene_solver_store(s, o->key, x, ctx->err);
    }
    int v = 0;
    if ((st = get_int_in(ctx, sol, "solver", o->key, (int)o->min, (int)o->max, &v)) != VDBS_OK)
        return st;
    return vdbs_solver_option_set(s, o, what, v, ctx->err); /* evenness: the option's check */
}

static vdbs_status parse_solver(const parse_ctx *ctx, const cJSON *sol, vdbs_scene *s)
{
    const char *keys[SOLVER_KEYS_MAX + 1] = {"method", "quality", "sky_directions"};
    int n = 3;
    const vdbs_solver *solver;
    for (int m = 0; (solver = vdbs_solver_at(m)) != NULL; ++m)
        for (int o = 0; o < solver->option_count && n < SOLVER_KEYS_MAX; ++o)
            keys[n++] = solver->options[o].key;
    keys[n] = NULL;
    vdbs_status st;
    bool found = false;
    if ((st = expect_object(ctx, sol, "solver")) != VDBS_OK ||
        (st = check_keys(ctx, sol, "solver", keys, NULL)) != VDBS_OK)
        return st;
    char name[sizeof s->method];
    char what[PATH_LEN];
    if ((st = get_string(ctx, sol, "solver", "method", name, sizeof name, &found)) != VDBS_OK)
        return st;
    fmt_path(what, "%s: solver.method", ctx->prefix);
    if (found && (st = vdbs_scene_set_method(s, what, name, ctx->err)) != VDBS_OK)
        return st;
    if ((st = get_string(ctx, sol, "solver", "quality", name, sizeof name, &found)) != VDBS_OK)
        return st;
    fmt_path(what, "%s: solver.quality", ctx->prefix);
    if (found && (st = vdbs_scene_set_quality(s, what, name, ctx->err)) != VDBS_OK)
        return st;
    if ((st = get_int_in(ctx, sol, "solver", "sky_directions", 1, VDBS_MAX_SKY_DIRECTIONS,
                         &s->sky_directions)) != VDBS_OK)
        return st;
    for (int m = 0; (solver = vdbs_solver_at(m)) != NULL; ++m)
        for (int o = 0; o < solver->option_count; ++o)
            if ((st = parse_solver_option(ctx, sol, &solver->options[o], s)) != VDBS_OK)
                return st;
    return VDBS_OK;
}

/* One occluder into o (whose OBJ path goes into s->occluder_paths). Types and presence
 * are checked here, ranges by check_occluders_and_fog. */
static vdbs_status parse_occluder(const parse_ctx *ctx, const cJSON *obj, const char *path,
                                  vdbs_scene *s, vdbs_occluder *o)
{
    static const char *const obj_keys[] = {"type",       "file",   "translate", "scale",
                                           "rotate_deg", "albedo", NULL};
    static const char *const sphere_keys[] = {"type", "center", "radius", "albedo", NULL};
    static const char *const box_keys[] = {"type", "min", "max", "albedo", NULL};
    static const char *const plane_keys[] = {"type", "point", "normal", "albedo", NULL};
    /* Required keys per type, for a "missing" message before any other. */
    static const char *const obj_required[] = {"file", NULL};
    static const char *const sphere_required[] = {"center", "radius", NULL};
    static const char *const box_required[] = {"min", "max", NULL};
    static const char *const plane_required[] = {"point", "normal", NULL};
    const char *const *keys, *const *required;
    const char *hint;
    vdbs_status st;
    char tpath[PATH_LEN];

    if ((st = expect_object(ctx, obj, path)) != VDBS_OK)
        return st;
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(obj, "type");
    join_path(tpath, path, "type");
    if (!type)
        return fail(ctx, path, "missing \"type\" (obj, sphere, box or plane)");
    if (!cJSON_IsString(type))
        return fail(ctx, tpath, "expected a string, got %s", type_name(type));
    memset(o, 0, sizeof *o);
    o->scale[0] = o->scale[1] = o->scale[2] = 1.0;
    o->albedo[0] = o->albedo[1] = o->albedo[2] = 0.5;
    if (strcmp(type->valuestring, "obj") == 0) {
        o->type = VDBS_OCCLUDER_OBJ;
        keys = obj_keys;
        required = obj_required;
        hint = " (an obj occluder takes type, file, translate, scale, rotate_deg, albedo)";
    } else if (strcmp(type->valuestring, "sphere") == 0) {
        o->type = VDBS_OCCLUDER_SPHERE;
        keys = sphere_keys;
        required = sphere_required;
        hint = " (a sphere takes type, center, radius, albedo)";
    } else if (strcmp(type->valuestring, "box") == 0) {
        o->type = VDBS_OCCLUDER_BOX;
        keys = box_keys;
        required = box_required;
        hint = " (a box takes type, min, max, albedo)";
    } else if (strcmp(type->valuestring, "plane") == 0) {
        o->type = VDBS_OCCLUDER_PLANE;
        keys = plane_keys;
        required = plane_required;
        hint = " (a plane takes type, point, normal, albedo)";
    } else {
        return fail(ctx, tpath,
                    "unknown occluder type \"%.64s\" (expected obj, sphere, box or plane)",
                    type->valuestring);
    }
    if ((st = check_keys(ctx, obj, path, keys, hint)) != VDBS_OK)
        return st;
    for (const char *const *r = required; *r; ++r)
        if (!cJSON_GetObjectItemCaseSensitive(obj, *r))
            return fail(ctx, path, "missing \"%s\"", *r);
    if ((st = get_vec3(ctx, obj, path, "albedo", true, o->albedo)) != VDBS_OK)
        return st;
    switch (o->type) {
    case VDBS_OCCLUDER_OBJ: {
        char file[VDBS_PATH_MAX];
        bool found = false;
        if ((st = get_path(ctx, obj, path, "file", file, &found)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "translate", false, o->translate)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "scale", true, o->scale)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "rotate_deg", false, o->rotate_deg)) != VDBS_OK)
            return st;
        if (vdbs_occluder_set_obj_file(s, o, file, NULL) != VDBS_OK) {
            char fpath[PATH_LEN];
            join_path(fpath, path, "file");
            return fail(ctx, fpath, "the OBJ paths of a scene take at most %d bytes together",
                        VDBS_OCCLUDER_PATHS_MAX);
        }
        break;
    }
    case VDBS_OCCLUDER_SPHERE:
        if ((st = get_vec3(ctx, obj, path, "center", false, o->center)) != VDBS_OK ||
            (st = get_number(ctx, obj, path, "radius", &o->radius)) != VDBS_OK)
            return st;
        break;
    case VDBS_OCCLUDER_BOX:
        if ((st = get_vec3(ctx, obj, path, "min", false, o->min)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "max", false, o->max)) != VDBS_OK)
            return st;
        break;
    case VDBS_OCCLUDER_PLANE:
        if ((st = get_vec3(ctx, obj, path, "point", false, o->point)) != VDBS_OK ||
            (st = get_vec3(ctx, obj, path, "normal", false, o->normal)) != VDBS_OK)
            return st;
        break;
    }
    return VDBS_OK;
}

static vdbs_status parse_occluders(const parse_ctx *ctx, const cJSON *arr, vdbs_scene *s)
{
    vdbs_status st;
    if (!cJSON_IsArray(arr))
        return fail(ctx, "occluders", "expected an array, got %s", type_name(arr));
    int n = cJSON_GetArraySize(arr);
    if (n > VDBS_MAX_OCCLUDERS)
        return fail(ctx, "occluders", "%d occluders, at most %d are supported", n,
                    VDBS_MAX_OCCLUDERS);
    int i = 0;
    for (const cJSON *c = arr->child; c; c = c->next, ++i) {
        char path[PATH_LEN];
        fmt_path(path, "occluders[%d]", i);
        if ((st = parse_occluder(ctx, c, path, s, &s->occluders[i])) != VDBS_OK)
            return st;
    }
    s->occluder_count = n;
    return VDBS_OK;
}

static vdbs_status parse_fog(const parse_ctx *ctx, const cJSON *obj, vdbs_scene *s)
{
    static const char *const keys[] = {"sigma_t", "albedo", "g", "box", NULL};
    static const char *const box_keys[] = {"min", "max", NULL};
    vdbs_scene_fog *f = &s->fog;
    vdbs_status st;
    if ((st = expect_object(ctx, obj, "fog")) != VDBS_OK ||
        (st = check_keys(ctx, obj, "fog", keys, " (fog takes sigma_t, albedo, g, box)")) != VDBS_OK)
        return st;
    if (!cJSON_GetObjectItemCaseSensitive(obj, "sigma_t"))
        return fail(ctx, "fog", "missing \"sigma_t\" (extinction per world unit)");
    memset(f, 0, sizeof *f);
    f->albedo[0] = f->albedo[1] = f->albedo[2] = 1.0;
    if ((st = get_number(ctx, obj, "fog", "sigma_t", &f->sigma_t)) != VDBS_OK ||
        (st = get_vec3(ctx, obj, "fog", "albedo", true, f->albedo)) != VDBS_OK ||
        (cJSON_GetObjectItemCaseSensitive(obj, "g") &&
         (st = get_number(ctx, obj, "fog", "g", &f->g)) != VDBS_OK))
        return st;
    const cJSON *box = cJSON_GetObjectItemCaseSensitive(obj, "box");
    if (box) {
        if ((st = expect_object(ctx, box, "fog.box")) != VDBS_OK ||
            (st = check_keys(ctx, box, "fog.box", box_keys, " (a box takes min, max)")) != VDBS_OK)
            return st;
        if (!cJSON_GetObjectItemCaseSensitive(box, "min"))
            return fail(ctx, "fog.box", "missing \"min\"");
        if (!cJSON_GetObjectItemCaseSensitive(box, "max"))
            return fail(ctx, "fog.box", "missing \"max\"");
        if ((st = get_vec3(ctx, box, "fog.box", "min", false, f->box_min)) != VDBS_OK ||
            (st = get_vec3(ctx, box, "fog.box", "max", false, f->box_max)) != VDBS_OK)
            return st;
        f->has_box = 1;
    }
    f->present = 1;
    return VDBS_OK;
}

static vdbs_status check_occluders_and_fog(const parse_ctx *ctx, const vdbs_scene *s);

/* 1-based line and column of a byte offset, for JSON syntax errors. */
static void text_position(const char *text, const char *at, int *line, int *col)
{
    *line = 1;
    *col = 1;
    for (const char *p = text; p < at && *p; ++p) {
        if (*p == '\n') {
            ++*line;
            *col = 1;
        } else {
            ++*col;
        }
    }
}

static vdbs_status parse_scene(const parse_ctx *ctx, const char *json_text, vdbs_scene *out)
{
    static const char *const keys[] = {"volume",    "lights", "camera", "solver",
                                       "occluders", "fog",    NULL};
    const char *end = NULL;
    const cJSON *item;
    vdbs_status st = VDBS_OK;
    vdbs_scene *s;
    cJSON *root;

    if (!json_text) /* a caller's mistake, not the user's */
        return vdbs_error_set(ctx->err, VDBS_ERR_INTERNAL, "%s: no scene text", ctx->prefix);
    root = cJSON_ParseWithOpts(json_text, &end, 1);
    if (!root) {
        int line, col;
        text_position(json_text, end ? end : json_text, &line, &col);
        return fail(ctx, NULL, "invalid JSON at line %d, column %d", line, col);
    }
    /* Parse into a scratch scene so that `out` is untouched on error; on the heap, as
     * a scene is tens of KiB. */
    s = malloc(sizeof *s);
    if (!s) {
        cJSON_Delete(root);
        return vdbs_error_set(ctx->err, VDBS_ERR_NOMEM, "%s: out of memory", ctx->prefix);
    }
    vdbs_scene_init(s);
    if (!cJSON_IsObject(root))
        st = fail(ctx, NULL, "expected a JSON object at the top level, got %s", type_name(root));
    if (st == VDBS_OK)
        st = check_keys(ctx, root, "", keys,
                        " (expected volume, lights, camera, solver, occluders, fog)");
    if (st == VDBS_OK && (item = cJSON_GetObjectItemCaseSensitive(root, "volume")))
        st = parse_volume(ctx, item, s);
    if (st == VDBS_OK && (item = cJSON_GetObjectItemCaseSensitive(root, "lights")))
        st = parse_lights(ctx, item, s);
    if (st == VDBS_OK && (item = cJSON_GetObjectItemCaseSensitive(root, "camera")))
        st = parse_camera(ctx, item, s);
    if (st == VDBS_OK && (item = cJSON_GetObjectItemCaseSensitive(root, "solver")))
        st = parse_solver(ctx, item, s);
    if (st == VDBS_OK && (item = cJSON_GetObjectItemCaseSensitive(root, "occluders")))
        st = parse_occluders(ctx, item, s);
    if (st == VDBS_OK && (item = cJSON_GetObjectItemCaseSensitive(root, "fog")))
        st = parse_fog(ctx, item, s);
    /* Occluder and fog ranges are checked at load as well: a render without lights never
     * validates, and the viewer should not have to remember to. */
    if (st == VDBS_OK)
        st = check_occluders_and_fog(ctx, s);
    if (st == VDBS_OK)
        memcpy(out, s, sizeof *s);
    free(s);
    cJSON_Delete(root);
    return st;
}

vdbs_status vdbs_scene_parse(const char *json_text, const char *base_dir, vdbs_scene *scene,
                             vdbs_error *err)
{
    parse_ctx ctx = {"scene", base_dir, err};
    return parse_scene(&ctx, json_text, scene);
}

vdbs_status vdbs_scene_load(const char *path, vdbs_scene *scene, vdbs_error *err)
{
    char prefix[VDBS_PATH_MAX + 16];
    char base[VDBS_PATH_MAX];
    const char *base_dir = NULL;
    const char *slash;
    char *text = NULL;
    vdbs_status st;

    if (!path) /* a caller's mistake; a missing file is VDBS_ERR_INPUT below */
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "scene: no file given");
    snprintf(prefix, sizeof prefix, "scene %s", path);
    size_t len = 0;
    st = vdbs_read_file(path, prefix, SCENE_FILE_MAX, &text, &len, err);
    if (st != VDBS_OK)
        return st;
    if (strlen(text) != len) {
        free(text);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: not a text file (contains NUL bytes)",
                              prefix);
    }

    /* Relative paths in the scene are relative to the scene file's folder. */
    slash = strrchr(path, '/');
    if (slash) {
        size_t len = slash == path ? 1 : (size_t)(slash - path);
        if (len >= sizeof base)
            len = sizeof base - 1;
        memcpy(base, path, len);
        base[len] = '\0';
        base_dir = base;
    }
    parse_ctx ctx = {prefix, base_dir, err};
    st = parse_scene(&ctx, text, scene);
    free(text);
    return st;
}

/* ---- serialisation ---- */

/* Shortest of %.15g..%.17g that reads back to the same double, so parse(to_json(s)) is
 * bit-exact (cJSON's own printer accepts a 1-ulp error). Non-finite values have no JSON
 * form and become null, which the parser rejects: validate first. */

/* The shortest of %.15g, %.16g and %.17g that reads back as v; "null" if not finite. */
static void format_double(double v, char *buf, size_t size)
{
    if (!isfinite(v)) {
        snprintf(buf, size, "null");
        return;
    }
    for (int prec = 15; prec <= 17; ++prec) {
        snprintf(buf, size, "%.*g", prec, v);
        if (strtod(buf, NULL) == v)
            break;
    }
    /* printf follows the C locale's decimal point; JSON always uses '.'. */
    const char *dp = localeconv()->decimal_point;
    if (dp && dp[0] && dp[0] != '.' && !dp[1])
        for (char *p = buf; *p; ++p)
            if (*p == dp[0])
                *p = '.';
}

static bool add_number(cJSON *obj, const char *key, double v)
{
    char buf[64];
    format_double(v, buf, sizeof buf);
    cJSON *item = cJSON_CreateRaw(buf);
    return item && cJSON_AddItemToObject(obj, key, item);
}

static bool add_int(cJSON *obj, const char *key, int v)
{
    char buf[32];
    snprintf(buf, sizeof buf, "%d", v);
    cJSON *item = cJSON_CreateRaw(buf);
    return item && cJSON_AddItemToObject(obj, key, item);
}

static bool add_vec3(cJSON *obj, const char *key, const double v[3])
{
    cJSON *arr = cJSON_CreateArray();
    if (!arr || !cJSON_AddItemToObject(obj, key, arr))
        return false;
    for (int i = 0; i < 3; ++i) {
        char buf[64];
        format_double(v[i], buf, sizeof buf);
        cJSON *item = cJSON_CreateRaw(buf);
        if (!item || !cJSON_AddItemToArray(arr, item))
            return false;
    }
    return true;
}

static bool add_string(cJSON *obj, const char *key, const char *v)
{
    return cJSON_AddStringToObject(obj, key, v) != NULL;
}

static bool add_light(cJSON *arr, const vdbs_scene *s, const vdbs_light *l)
{
    cJSON *o = cJSON_CreateObject();
    bool ok = o && cJSON_AddItemToArray(arr, o);
    if (!ok)
        return false;
    switch (l->type) {
    case VDBS_LIGHT_SUN:
        ok = add_string(o, "type", "sun") && add_vec3(o, "direction", l->direction) &&
             add_vec3(o, "irradiance", l->color) &&
             add_number(o, "angular_diameter_deg", l->angular_diameter_deg);
        break;
    case VDBS_LIGHT_POINT:
        ok = add_string(o, "type", "point") && add_vec3(o, "position", l->position) &&
             add_vec3(o, "intensity", l->color);
        break;
    case VDBS_LIGHT_ENV:
        ok = add_string(o, "type", "env");
        if (vdbs_light_env_file(s, l)[0])
            ok = ok && add_string(o, "file", vdbs_light_env_file(s, l)) &&
                 add_number(o, "scale", l->env_scale);
        else
            ok = ok && add_vec3(o, "color", l->color);
        break;
    default:
        ok = add_string(o, "type", "invalid");
        break;
    }
    return ok;
}

static bool add_occluder(cJSON *arr, const vdbs_scene *s, const vdbs_occluder *o)
{
    cJSON *j = cJSON_CreateObject();
    bool ok = j && cJSON_AddItemToArray(arr, j);
    if (!ok)
        return false;
    switch (o->type) {
    case VDBS_OCCLUDER_OBJ:
        ok = add_string(j, "type", "obj") && add_string(j, "file", vdbs_occluder_obj_file(s, o)) &&
             add_vec3(j, "translate", o->translate) && add_vec3(j, "scale", o->scale) &&
             add_vec3(j, "rotate_deg", o->rotate_deg);
        break;
    case VDBS_OCCLUDER_SPHERE:
        ok = add_string(j, "type", "sphere") && add_vec3(j, "center", o->center) &&
             add_number(j, "radius", o->radius);
        break;
    case VDBS_OCCLUDER_BOX:
        ok = add_string(j, "type", "box") && add_vec3(j, "min", o->min) &&
             add_vec3(j, "max", o->max);
        break;
    case VDBS_OCCLUDER_PLANE:
        ok = add_string(j, "type", "plane") && add_vec3(j, "point", o->point) &&
             add_vec3(j, "normal", o->normal);
        break;
    default:
        ok = add_string(j, "type", "invalid");
        break;
    }
    return ok && add_vec3(j, "albedo", o->albedo);
}

static bool add_fog(cJSON *root, const vdbs_scene_fog *f)
{
    cJSON *j = cJSON_AddObjectToObject(root, "fog");
    bool ok = j && add_number(j, "sigma_t", f->sigma_t) && add_vec3(j, "albedo", f->albedo) &&
              add_number(j, "g", f->g);
    if (ok && f->has_box) {
        cJSON *box = cJSON_AddObjectToObject(j, "box");
        ok = box && add_vec3(box, "min", f->box_min) && add_vec3(box, "max", f->box_max);
    }
    return ok;
}

/* Every solver's options in table order: a choice always (by name), a number only when
 * set (0 is its default). */
static bool add_solver_options(cJSON *sol, const vdbs_scene *s)
{
    const vdbs_solver *solver;
    for (int m = 0; (solver = vdbs_solver_at(m)) != NULL; ++m)
        for (int i = 0; i < solver->option_count; ++i) {
            const vdbs_solver_option *o = &solver->options[i];
            const double v = vdbs_scene_solver_value(s, o->key);
            bool ok = o->kind == VDBS_OPTION_CHOICE
                          ? add_string(sol, o->key, vdbs_solver_option_choice(s, o))
                      : v == 0.0                      ? true
                      : o->kind == VDBS_OPTION_NUMBER ? add_number(sol, o->key, v)
                                                      : add_int(sol, o->key, (int)v);
            if (!ok)
                return false;
        }
    return true;
}

char *vdbs_scene_to_json(const vdbs_scene *s)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *vol = NULL, *lights = NULL, *sol = NULL, *cam = NULL;
    char *text = NULL;
    bool ok = root != NULL;

    /* The cJSON_Add*ToObject helpers attach as they create, so root owns everything. */
    ok = ok && (vol = cJSON_AddObjectToObject(root, "volume")) != NULL;
    if (ok && s->volume_file[0])
        ok = add_string(vol, "file", s->volume_file);
    if (ok && s->grid[0]) {
        /* A name containing '@' needs an explicit index to read back unambiguously. */
        char spec[300];
        if (s->grid_index != 0 || strchr(s->grid, '@'))
            snprintf(spec, sizeof spec, "%s@%d", s->grid, s->grid_index);
        else
            snprintf(spec, sizeof spec, "%s", s->grid);
        ok = add_string(vol, "grid", spec);
    }
    if (ok && s->density_target_depth > 0.0) {
        char spec[64], num[48];
        format_double(s->density_target_depth, num, sizeof num);
        snprintf(spec, sizeof spec, "auto:%s", num);
        ok = add_string(vol, "density_scale", spec);
    } else {
        ok = ok && add_number(vol, "density_scale", s->density_scale);
    }
    ok = ok && add_vec3(vol, "albedo", s->albedo) && add_number(vol, "g", s->g);

    ok = ok && (lights = cJSON_AddArrayToObject(root, "lights")) != NULL;
    for (int i = 0; ok && i < s->light_count && i < VDBS_MAX_LIGHTS; ++i)
        ok = add_light(lights, s, &s->lights[i]);

    if (ok && s->camera.present) {
        const vdbs_camera *c = &s->camera;
        ok = (cam = cJSON_AddObjectToObject(root, "camera")) != NULL &&
             add_vec3(cam, "position", c->position) && add_vec3(cam, "target", c->target) &&
             add_vec3(cam, "up", c->up) && add_number(cam, "fov_deg", c->fov_deg) &&
             add_int(cam, "width", c->width) && add_int(cam, "height", c->height);
    }

    ok = ok && (sol = cJSON_AddObjectToObject(root, "solver")) != NULL &&
         add_string(sol, "method", s->method) && add_string(sol, "quality", s->quality) &&
         (s->sky_directions == 0 || add_int(sol, "sky_directions", s->sky_directions)) &&
         add_solver_options(sol, s);
    /* Written only when there are any, so that scenes without them read as before. */
    if (ok && s->occluder_count > 0) {
        cJSON *occ = cJSON_AddArrayToObject(root, "occluders");
        ok = occ != NULL;
        for (int i = 0; ok && i < s->occluder_count && i < VDBS_MAX_OCCLUDERS; ++i)
            ok = add_occluder(occ, s, &s->occluders[i]);
    }
    if (ok && s->fog.present)
        ok = add_fog(root, &s->fog);
    if (ok)
        text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text;
}

/* ---- validation ---- */

static bool finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

/* Length computed after scaling by the largest component, so tiny vectors whose squared
 * length underflows still count as non-zero. */
static double norm3(const double v[3])
{
    double m = fmax(fabs(v[0]), fmax(fabs(v[1]), fabs(v[2])));
    if (m == 0.0 || !isfinite(m))
        return m;
    double x = v[0] / m, y = v[1] / m, z = v[2] / m;
    return m * sqrt(x * x + y * y + z * z);
}

static void normalise3(double v[3])
{
    double m = fmax(fabs(v[0]), fmax(fabs(v[1]), fabs(v[2])));
    for (int i = 0; i < 3; ++i)
        v[i] /= m;
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; ++i)
        v[i] /= n;
}

static vdbs_status check_colour(const parse_ctx *ctx, const char *path, const double c[3])
{
    char what[PATH_LEN];
    fmt_path(what, "%s: %s", ctx->prefix, path);
    return vdbs_check_colour(what, c, ctx->err);
}

static vdbs_status validate_light(const parse_ctx *ctx, const vdbs_scene *s, int i,
                                  const vdbs_light *l)
{
    char path[PATH_LEN];
    vdbs_status st;
    switch (l->type) {
    case VDBS_LIGHT_SUN:
        fmt_path(path, "lights[%d].direction", i);
        if (!finite3(l->direction))
            return fail(ctx, path, "must be 3 finite numbers");
        if (norm3(l->direction) == 0.0)
            return fail(ctx, path, "must be a non-zero vector");
        fmt_path(path, "lights[%d].irradiance", i);
        if ((st = check_colour(ctx, path, l->color)) != VDBS_OK)
            return st;
        fmt_path(path, "lights[%d].angular_diameter_deg", i);
        if (!(l->angular_diameter_deg >= 0.0 && l->angular_diameter_deg < 180.0))
            return fail(ctx, path, "must be in [0, 180), got %g", l->angular_diameter_deg);
        return VDBS_OK;
    case VDBS_LIGHT_POINT:
        fmt_path(path, "lights[%d].position", i);
        if (!finite3(l->position))
            return fail(ctx, path, "must be 3 finite numbers");
        fmt_path(path, "lights[%d].intensity", i);
        return check_colour(ctx, path, l->color);
    case VDBS_LIGHT_ENV:
        if (l->env_map != 0 && !vdbs_light_env_file(s, l)[0])
            return vdbs_error_set(ctx->err, VDBS_ERR_INTERNAL,
                                  "%s: lights[%d]: env_map %d is not a path of this scene (copy "
                                  "lights between scenes with vdbs_scene_copy_lights)",
                                  ctx->prefix, i, l->env_map);
        if (l->env_map != 0) {
            fmt_path(path, "lights[%d].scale", i);
            if (!(isfinite(l->env_scale) && l->env_scale >= 0.0))
                return fail(ctx, path, "must be finite and >= 0, got %g", l->env_scale);
            return VDBS_OK;
        }
        fmt_path(path, "lights[%d].color", i);
        return check_colour(ctx, path, l->color);
    }
    fmt_path(path, "lights[%d].type", i);
    return fail(ctx, path, "invalid light type %d", (int)l->type);
}

static vdbs_status check_unit_range(const parse_ctx *ctx, const char *path, const double c[3])
{
    for (int i = 0; i < 3; ++i)
        if (!(c[i] >= 0.0 && c[i] <= 1.0))
            return fail(ctx, path, "each component must be in [0, 1], got [%g, %g, %g]", c[0], c[1],
                        c[2]);
    return VDBS_OK;
}

static vdbs_status check_finite3(const parse_ctx *ctx, const char *path, const double v[3])
{
    if (!finite3(v))
        return fail(ctx, path, "must be 3 finite numbers");
    return VDBS_OK;
}

/* min < max on every axis (a flat or inverted box has no inside). */
static vdbs_status check_box(const parse_ctx *ctx, const char *min_path, const char *max_path,
                             const double lo[3], const double hi[3])
{
    vdbs_status st;
    if ((st = check_finite3(ctx, min_path, lo)) != VDBS_OK ||
        (st = check_finite3(ctx, max_path, hi)) != VDBS_OK)
        return st;
    for (int a = 0; a < 3; ++a)
        if (!(lo[a] < hi[a]))
            return fail(ctx, max_path,
                        "must exceed min on every axis, got min [%g, %g, %g], max "
                        "[%g, %g, %g]",
                        lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    return VDBS_OK;
}

static vdbs_status check_occluder(const parse_ctx *ctx, const vdbs_scene *s, int i,
                                  const vdbs_occluder *o)
{
    char path[PATH_LEN], path2[PATH_LEN];
    vdbs_status st;
    fmt_path(path, "occluders[%d].albedo", i);
    if ((st = check_unit_range(ctx, path, o->albedo)) != VDBS_OK)
        return st;
    switch (o->type) {
    case VDBS_OCCLUDER_OBJ:
        if (!vdbs_occluder_obj_file(s, o)[0])
            return vdbs_error_set(ctx->err, VDBS_ERR_INTERNAL,
                                  "%s: occluders[%d]: obj_file %d is not a path of this scene",
                                  ctx->prefix, i, o->obj_file);
        fmt_path(path, "occluders[%d].translate", i);
        if ((st = check_finite3(ctx, path, o->translate)) != VDBS_OK)
            return st;
        fmt_path(path, "occluders[%d].rotate_deg", i);
        if ((st = check_finite3(ctx, path, o->rotate_deg)) != VDBS_OK)
            return st;
        fmt_path(path, "occluders[%d].scale", i);
        /* Positive only: a mirroring scale would turn the triangles inside out. */
        if (!finite3(o->scale) || !(o->scale[0] > 0.0 && o->scale[1] > 0.0 && o->scale[2] > 0.0))
            return fail(ctx, path, "each component must be finite and > 0, got [%g, %g, %g]",
                        o->scale[0], o->scale[1], o->scale[2]);
        return VDBS_OK;
    case VDBS_OCCLUDER_SPHERE:
        fmt_path(path, "occluders[%d].center", i);
        if ((st = check_finite3(ctx, path, o->center)) != VDBS_OK)
            return st;
        fmt_path(path, "occluders[%d].radius", i);
        if (!(isfinite(o->radius) && o->radius > 0.0))
            return fail(ctx, path, "must be finite and > 0, got %g", o->radius);
        return VDBS_OK;
    case VDBS_OCCLUDER_BOX:
        fmt_path(path, "occluders[%d].min", i);
        fmt_path(path2, "occluders[%d].max", i);
        return check_box(ctx, path, path2, o->min, o->max);
    case VDBS_OCCLUDER_PLANE:
        fmt_path(path, "occluders[%d].point", i);
        if ((st = check_finite3(ctx, path, o->point)) != VDBS_OK)
            return st;
        fmt_path(path, "occluders[%d].normal", i);
        if ((st = check_finite3(ctx, path, o->normal)) != VDBS_OK)
            return st;
        if (norm3(o->normal) == 0.0)
            return fail(ctx, path, "must be a non-zero vector");
        return VDBS_OK;
    }
    fmt_path(path, "occluders[%d].type", i);
    return fail(ctx, path, "invalid occluder type %d", (int)o->type);
}

static vdbs_status check_occluders_and_fog(const parse_ctx *ctx, const vdbs_scene *s)
{
    vdbs_status st;
    if (s->occluder_count < 0 || s->occluder_count > VDBS_MAX_OCCLUDERS)
        return fail(ctx, "occluders", "%d occluders, at most %d are supported", s->occluder_count,
                    VDBS_MAX_OCCLUDERS);
    for (int i = 0; i < s->occluder_count; ++i)
        if ((st = check_occluder(ctx, s, i, &s->occluders[i])) != VDBS_OK)
            return st;
    const vdbs_scene_fog *f = &s->fog;
    if (!f->present)
        return VDBS_OK;
    if (!(isfinite(f->sigma_t) && f->sigma_t >= 0.0))
        return fail(ctx, "fog.sigma_t", "must be finite and >= 0, got %g", f->sigma_t);
    if ((st = check_unit_range(ctx, "fog.albedo", f->albedo)) != VDBS_OK)
        return st;
    if (!(isfinite(f->g) && fabs(f->g) <= 0.999))
        return fail(ctx, "fog.g", "must be in [-0.999, 0.999], got %g", f->g);
    if (f->has_box)
        return check_box(ctx, "fog.box.min", "fog.box.max", f->box_min, f->box_max);
    return VDBS_OK;
}

static vdbs_status validate_camera(const parse_ctx *ctx, const vdbs_camera *c)
{
    double fwd[3], cr[3];
    if (!finite3(c->position))
        return fail(ctx, "camera.position", "must be 3 finite numbers");
    if (!finite3(c->target))
        return fail(ctx, "camera.target", "must be 3 finite numbers");
    if (!finite3(c->up))
        return fail(ctx, "camera.up", "must be 3 finite numbers");
    if (!(c->fov_deg > 0.0 && c->fov_deg < 180.0))
        return fail(ctx, "camera.fov_deg", "must be in (0, 180), got %g", c->fov_deg);
    if (c->width < 1 || c->width > 16384)
        return fail(ctx, "camera.width", "must be in [1, 16384], got %d", c->width);
    if (c->height < 1 || c->height > 16384)
        return fail(ctx, "camera.height", "must be in [1, 16384], got %d", c->height);
    for (int i = 0; i < 3; ++i)
        fwd[i] = c->target[i] - c->position[i];
    if (!finite3(fwd) || norm3(fwd) == 0.0)
        return fail(ctx, "camera.target", "must differ from camera.position");
    if (norm3(c->up) == 0.0)
        return fail(ctx, "camera.up", "must be a non-zero vector");
    double u[3] = {c->up[0], c->up[1], c->up[2]};
    normalise3(fwd);
    normalise3(u);
    cr[0] = fwd[1] * u[2] - fwd[2] * u[1];
    cr[1] = fwd[2] * u[0] - fwd[0] * u[2];
    cr[2] = fwd[0] * u[1] - fwd[1] * u[0];
    /* sin(angle) below 1e-6: the right vector (forward x up) would be meaningless. */
    if (norm3(cr) < 1e-6)
        return fail(ctx, "camera.up", "is parallel to the view direction (target - position)");
    return VDBS_OK;
}

vdbs_status vdbs_scene_validate(vdbs_scene *s, vdbs_error *err)
{
    return vdbs_scene_validate_opt(s, 0, err);
}

vdbs_status vdbs_scene_validate_opt(vdbs_scene *s, int lights_optional, vdbs_error *err)
{
    parse_ctx ctx = {"scene", NULL, err};
    vdbs_status st;

    if (!(isfinite(s->density_scale) && s->density_scale >= 0.0))
        return fail(&ctx, "volume.density_scale", "must be finite and >= 0, got %g",
                    s->density_scale);
    if ((st = vdbs_check_albedo("scene: volume.albedo", s->albedo, err)) != VDBS_OK ||
        (st = vdbs_check_g("scene: volume.g", s->g, err)) != VDBS_OK)
        return st;
    if (s->grid_index < 0)
        return fail(&ctx, "volume.grid", "negative grid index %d", s->grid_index);
    if ((st = check_method("scene: solver.method", s->method, err)) != VDBS_OK ||
        (st = check_quality("scene: solver.quality", s->quality, err)) != VDBS_OK)
        return st;
    if (s->light_count < 0 || s->light_count > VDBS_MAX_LIGHTS)
        return fail(&ctx, "lights", "%d lights, at most %d are supported", s->light_count,
                    VDBS_MAX_LIGHTS);
    if (s->light_count == 0 && !lights_optional)
        return fail(&ctx, "lights", "%s", VDBS_NO_LIGHT_MESSAGE);
    for (int i = 0; i < s->light_count; ++i)
        if ((st = validate_light(&ctx, s, i, &s->lights[i])) != VDBS_OK)
            return st;
    if (s->camera.present && (st = validate_camera(&ctx, &s->camera)) != VDBS_OK)
        return st;
    if ((st = vdbs_solver_options_check(s, "scene: ", err)) != VDBS_OK)
        return st;
    if ((st = check_occluders_and_fog(&ctx, s)) != VDBS_OK)
        return st;
    /* Normalise only once everything is known to be valid: a failed validation leaves
     * the scene as it was. */
    for (int i = 0; i < s->light_count; ++i)
        if (s->lights[i].type == VDBS_LIGHT_SUN)
            normalise3(s->lights[i].direction);
    for (int i = 0; i < s->occluder_count; ++i)
        if (s->occluders[i].type == VDBS_OCCLUDER_PLANE)
            normalise3(s->occluders[i].normal);
    return VDBS_OK;
}
