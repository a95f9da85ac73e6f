#define _POSIX_C_SOURCE 200809L
#include "options.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/mesh.h"
#include "vdbscatter/message.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/suggest.h"

static const vdbs_arg_option *find_option(const vdbs_arg_option *options, const char *name,
                                          size_t len)
{
    for (const vdbs_arg_option *o = options; o->name; ++o)
        if (strlen(o->name) == len && strncmp(o->name, name, len) == 0)
            return o;
    return NULL;
}

/* "unknown option '--densty-scale' (did you mean --density-scale?)". */
static vdbs_status unknown_option(const vdbs_arg_option *options, const char *arg, size_t len,
                                  vdbs_error *err)
{
    const char *names[VDBS_OPTIONS_MAX + 1];
    int n = 0;
    for (const vdbs_arg_option *o = options; o->name && n < VDBS_OPTIONS_MAX; ++o)
        names[n++] = o->name;
    names[n] = NULL;
    char word[128];
    snprintf(word, sizeof word, "%.*s", (int)(len < sizeof word ? len : sizeof word - 1), arg);
    const char *near = vdbs_suggest(word, names);
    if (near)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown option '%s' (did you mean %s?)", word,
                              near);
    return vdbs_error_set(err, VDBS_ERR_INPUT, "unknown option '%s' (see --help)", word);
}

vdbs_status vdbs_options_parse(int argc, char **argv, const vdbs_arg_option *options,
                               vdbs_options_args *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    for (int i = 0; i < argc; ++i) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            out->help = 1;
            continue;
        }
        if (a[0] != '-' || strcmp(a, "-") == 0) {
            if (out->positional_count == (int)(sizeof out->positional / sizeof *out->positional))
                return vdbs_error_set(err, VDBS_ERR_INPUT, "too many arguments ('%s')", a);
            out->positional[out->positional_count++] = a;
            continue;
        }
        const char *eq = strchr(a, '=');
        size_t len = eq ? (size_t)(eq - a) : strlen(a);
        const vdbs_arg_option *o = find_option(options, a, len);
        if (!o)
            return unknown_option(options, a, len, err);
        if (out->count == VDBS_OPTIONS_MAX_ARGS)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "too many options");
        vdbs_options_arg *arg = &out->args[out->count++];
        arg->option = o;
        if (o->kind == VDBS_ARG_FLAG) {
            if (eq)
                return vdbs_error_set(err, VDBS_ERR_INPUT, "%s takes no value", o->name);
            continue;
        }
        if (eq) {
            arg->value = eq + 1;
        } else {
            if (i + 1 >= argc)
                return vdbs_error_set(err, VDBS_ERR_INPUT, "%s needs a value", o->name);
            arg->value = argv[++i];
        }
    }
    return VDBS_OK;
}

int vdbs_command_open(const vdbs_command_spec *command, int argc, char **argv,
                      vdbs_options_args *args)
{
    vdbs_error err;
    if (vdbs_options_parse(argc, argv, command->options, args, &err) != VDBS_OK)
        return vdbs_command_fail(command->name, 2, err.message);
    if (args->help) {
        vdbs_command_out("%s", command->help);
        if (command->more_help)
            command->more_help();
        return VDBS_EXIT_OK;
    }
    if (args->positional_count < command->min_positional ||
        args->positional_count > command->max_positional)
        return vdbs_command_fail(command->name, 2, command->positional_error);
    return VDBS_COMMAND_CONTINUE;
}

const char *vdbs_options_value(const vdbs_options_args *args, const char *name)
{
    const char *v = NULL;
    for (int i = 0; i < args->count; ++i)
        if (strcmp(args->args[i].option->name, name) == 0)
            v = args->args[i].value;
    return v;
}

int vdbs_options_flag(const vdbs_options_args *args, const char *name)
{
    for (int i = 0; i < args->count; ++i)
        if (strcmp(args->args[i].option->name, name) == 0)
            return 1;
    return 0;
}

const char *vdbs_options_output(const vdbs_options_args *args)
{
    const char *v = NULL;
    for (int i = 0; i < args->count; ++i) {
        const char *name = args->args[i].option->name;
        if (strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0)
            v = args->args[i].value;
    }
    return v;
}

vdbs_status vdbs_options_number(const char *flag, const char *text, double *out, vdbs_error *err)
{
    char *end = NULL;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || errno == ERANGE || !isfinite(v))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected a finite number, got '%s'", flag,
                              text);
    *out = v;
    return VDBS_OK;
}

vdbs_status vdbs_options_integer(const char *flag, const char *text, long lo, long hi, long *out,
                                 vdbs_error *err)
{
    char *end = NULL;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (end == text || *end != '\0' || errno == ERANGE || v < lo || v > hi)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: expected an integer in [%ld, %ld], got '%s'", flag, lo, hi,
                              text);
    *out = v;
    return VDBS_OK;
}

vdbs_status vdbs_options_triple(const char *flag, const char *text, int allow_scalar, double out[3],
                                vdbs_error *err)
{
    char buf[256];
    if (strlen(text) >= sizeof buf)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: value too long", flag);
    strcpy(buf, text);
    int n = 0;
    char *save = NULL;
    for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (n == 3 || vdbs_options_number(flag, tok, &out[n], NULL) != VDBS_OK)
            goto bad;
        ++n;
    }
    if (n == 1 && allow_scalar) {
        out[1] = out[2] = out[0];
        return VDBS_OK;
    }
    if (n == 3 && text[strlen(text) - 1] != ',' && text[0] != ',' && !strstr(text, ",,"))
        return VDBS_OK;
bad:
    return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected %s3 finite numbers X,Y,Z, got '%s'",
                          flag, allow_scalar ? "one or " : "", text);
}

/* "X,Y,Z[:R,G,B]" for --sun and --point. */
static vdbs_status parse_light(const char *flag, const char *text, double xyz[3], double rgb[3],
                               vdbs_error *err)
{
    char head[256];
    const char *colon = strchr(text, ':');
    size_t len = colon ? (size_t)(colon - text) : strlen(text);
    if (len >= sizeof head)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: value too long", flag);
    memcpy(head, text, len);
    head[len] = '\0';
    rgb[0] = rgb[1] = rgb[2] = 1.0;
    if (vdbs_options_triple(flag, head, 0, xyz, NULL) != VDBS_OK ||
        (colon && vdbs_options_triple(flag, colon + 1, 1, rgb, NULL) != VDBS_OK))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: expected X,Y,Z[:R,G,B] with finite numbers, got '%s'", flag,
                              text);
    return VDBS_OK;
}

/* --env R,G,B (or one grey value), or --env FILE[:SCALE]: a lat-long map. */
static vdbs_status parse_env(vdbs_scene *scene, vdbs_light *light, const char *text,
                             vdbs_error *err)
{
    if (vdbs_options_triple("--env", text, 1, light->color, NULL) == VDBS_OK)
        return VDBS_OK;
    char path[VDBS_PATH_MAX];
    if (strlen(text) >= sizeof path)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--env: path too long");
    strcpy(path, text);
    light->color[0] = light->color[1] = light->color[2] = 1.0;
    char *colon = strrchr(path, ':');
    if (colon && vdbs_options_number("--env", colon + 1, &light->env_scale, NULL) == VDBS_OK) {
        *colon = '\0';
        if (!(light->env_scale >= 0.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--env: the scale must be >= 0, got '%s'",
                                  colon + 1);
    }
    if (!path[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--env: expected R,G,B or FILE[:SCALE], got '%s'", text);
    return vdbs_light_set_env_file(scene, light, path, err);
}

/* The state of the walk over the flags: light flags replace the scene's lights at the
 * first of them. */
typedef struct scene_build {
    vdbs_scene *scene;
    int lights_replaced;
} scene_build;

static vdbs_status set_grid(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    (void)name;
    return vdbs_scene_set_grid(b->scene, value, err);
}

static vdbs_status set_density_scale(scene_build *b, const char *name, const char *value,
                                     vdbs_error *err)
{
    return vdbs_scene_set_density_scale(b->scene, name, value, err);
}

static vdbs_status set_albedo(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    vdbs_status st = vdbs_options_triple(name, value, 1, b->scene->albedo, err);
    return st == VDBS_OK ? vdbs_check_albedo(name, b->scene->albedo, err) : st;
}

static vdbs_status set_g(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    double x = 0.0;
    vdbs_status st = vdbs_options_number(name, value, &x, err);
    if (st == VDBS_OK)
        st = vdbs_check_g(name, x, err);
    b->scene->g = x;
    return st;
}

static vdbs_status set_sky_directions(scene_build *b, const char *name, const char *value,
                                      vdbs_error *err)
{
    long k = 0;
    vdbs_status st = vdbs_options_integer(name, value, 1, VDBS_MAX_SKY_DIRECTIONS, &k, err);
    b->scene->sky_directions = (int)k;
    return st;
}

static vdbs_status set_method(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    if (strcmp(value, "auto") == 0) /* bake's planner picks it (plan.h) */
        return VDBS_OK;
    return vdbs_scene_set_method(b->scene, name, value, err);
}

static vdbs_status set_quality(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    return vdbs_scene_set_quality(b->scene, name, value, err);
}

/* The next light of the scene, zeroed, or NULL past VDBS_MAX_LIGHTS. It counts once
 * add_light has checked it. */
static vdbs_light *next_light(scene_build *b, const char *name, vdbs_light_type type,
                              vdbs_error *err)
{
    vdbs_scene *scene = b->scene;
    if (!b->lights_replaced) {
        vdbs_scene_clear_lights(scene); /* the scene file's env-map paths too */
        b->lights_replaced = 1;
    }
    if (scene->light_count == VDBS_MAX_LIGHTS) {
        vdbs_error_set(err, VDBS_ERR_INPUT, "%s: more than %d lights", name, VDBS_MAX_LIGHTS);
        return NULL;
    }
    vdbs_light *light = &scene->lights[scene->light_count];
    memset(light, 0, sizeof *light);
    light->env_scale = 1.0;
    light->type = type;
    return light;
}

/* Checks the colour of the light next_light gave once its value parsed (st), and counts it. */
static vdbs_status add_light(scene_build *b, const char *name, vdbs_status st, vdbs_error *err)
{
    vdbs_scene *scene = b->scene;
    if (st == VDBS_OK)
        st = vdbs_check_colour(name, scene->lights[scene->light_count].color, err);
    scene->light_count++;
    return st;
}

static vdbs_status set_sun(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    vdbs_light *light = next_light(b, name, VDBS_LIGHT_SUN, err);
    if (!light)
        return VDBS_ERR_INPUT;
    vdbs_status st = parse_light(name, value, light->direction, light->color, err);
    const double *d = light->direction;
    if (st == VDBS_OK && d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0)
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "--sun: the direction must not be zero, got '%s'",
                            value);
    return add_light(b, name, st, err);
}

static vdbs_status set_point(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    vdbs_light *light = next_light(b, name, VDBS_LIGHT_POINT, err);
    if (!light)
        return VDBS_ERR_INPUT;
    return add_light(b, name, parse_light(name, value, light->position, light->color, err), err);
}

static vdbs_status set_env(scene_build *b, const char *name, const char *value, vdbs_error *err)
{
    vdbs_light *light = next_light(b, name, VDBS_LIGHT_ENV, err);
    if (!light)
        return VDBS_ERR_INPUT;
    return add_light(b, name, parse_env(b->scene, light, value, err), err);
}

/* The scene flags that every solver shares: how each sets the scene, and which fields of a
 * lit VDB's baked scene it overrides (VDBS_SCENE_SET_*, vdbs_options_scene_flags). */
typedef struct scene_flag {
    const char *name;
    unsigned sets;
    vdbs_status (*set)(scene_build *b, const char *name, const char *value, vdbs_error *err);
} scene_flag;

static const scene_flag scene_flags[] = {
    {"--scene", VDBS_SCENE_FROM_FILE, NULL}, /* loaded before the walk */
    {"--grid", VDBS_SCENE_SET_GRID, set_grid},
    {"--density-scale", VDBS_SCENE_SET_DENSITY_SCALE, set_density_scale},
    {"--albedo", VDBS_SCENE_SET_ALBEDO, set_albedo},
    {"--g", VDBS_SCENE_SET_G, set_g},
    {"--sky-directions", VDBS_SCENE_SET_SKY_DIRECTIONS, set_sky_directions},
    {"--method", 0, set_method}, /* a lit VDB is not baked again */
    {"--quality", VDBS_SCENE_SET_QUALITY, set_quality},
    {"--sun", VDBS_SCENE_SET_LIGHTS, set_sun},
    {"--point", VDBS_SCENE_SET_LIGHTS, set_point},
    {"--env", VDBS_SCENE_SET_LIGHTS, set_env},
    {NULL, 0, NULL},
};

static const scene_flag *find_scene_flag(const char *name)
{
    for (const scene_flag *f = scene_flags; f->name; ++f)
        if (strcmp(f->name, name) == 0)
            return f;
    return NULL;
}

vdbs_status vdbs_options_build_scene(const vdbs_options_args *args, vdbs_scene *scene,
                                     int allow_no_lights, vdbs_error *err)
{
    vdbs_status st;
    vdbs_scene_init(scene);
    const char *scene_file = vdbs_options_value(args, "--scene");
    if (scene_file && (st = vdbs_scene_load(scene_file, scene, err)) != VDBS_OK)
        return st;
    scene_build b = {scene, 0};
    int handled = 0;
    for (int i = 0; i < args->count; ++i) {
        const char *name = args->args[i].option->name;
        const char *value = args->args[i].value;
        const scene_flag *flag = find_scene_flag(name);
        if (flag)
            st = flag->set ? flag->set(&b, name, value, err) : VDBS_OK;
        else /* a solver's own flag (below), or the command's (-o, --backend, ...) */
            st = vdbs_options_solver_flag(name, value, scene, &handled, err);
        if (st != VDBS_OK)
            return st;
    }
    return vdbs_scene_validate_opt(scene, allow_no_lights, err);
}

vdbs_status vdbs_options_scene_occluders(const char *command, const vdbs_options_args *args,
                                         const vdbs_scene *scene, int quiet, vdbs_error *err)
{
    int count = scene->occluder_count;
    if (count == 0 && !scene->fog.present)
        return VDBS_OK;
    vdbs_error inner = {{0}};
    vdbs_status st = vdbs_occluders_check(scene, &inner);
    if (st != VDBS_OK) {
        const char *file = vdbs_options_value(args, "--scene");
        if (file)
            return vdbs_error_set(err, st, "scene %s: %s", file, inner.message);
        return vdbs_error_set(err, st, "scene: %s", inner.message);
    }
    char line[256];
    char occluders[64] = "";
    if (count > 0)
        snprintf(occluders, sizeof occluders, "%d occluder%s", count, count == 1 ? "" : "s");
    snprintf(line, sizeof line, "%s: ignoring %s%s%s of the scene (only vdbscatter-view draws %s)",
             command, occluders, count > 0 && scene->fog.present ? " and " : "",
             scene->fog.present ? "the fog" : "", count + scene->fog.present > 1 ? "them" : "it");
    vdbs_command_warn(&quiet, line);
    return VDBS_OK;
}

int vdbs_command_fail(const char *command, int status, const char *message)
{
    vdbs_command_error(command, status, message);
    return status == 2 ? VDBS_EXIT_USAGE : VDBS_EXIT_FAILURE;
}

void vdbs_command_warn(void *quiet, const char *message)
{
    if (quiet && *(const int *)quiet)
        return;
    vdbs_message_emitf(VDBS_MESSAGE_WARNING, "vdbscatter: warning: %s\n", message);
}

vdbs_status vdbs_options_s1(const vdbs_options_args *args, int *march, int *oversample,
                            vdbs_error *err)
{
    *march = 0;
    *oversample = 0;
    const char *s1 = vdbs_options_value(args, "--s1");
    if (s1 && strcmp(s1, "grid") != 0 && strcmp(s1, "march") != 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--s1: expected grid or march, got '%s'", s1);
    *march = s1 && strcmp(s1, "march") == 0;
    const char *text = vdbs_options_value(args, "--s1-oversample");
    long f = 0;
    if (text) {
        vdbs_status st = vdbs_options_integer("--s1-oversample", text, 1, 16, &f, err);
        if (st != VDBS_OK)
            return st;
        *oversample = (int)f;
    }
    return VDBS_OK;
}

vdbs_status vdbs_options_max_memory(const vdbs_options_args *args, int64_t *bytes, vdbs_error *err)
{
    *bytes = 0;
    const char *text = vdbs_options_value(args, "--max-memory");
    if (!text)
        return VDBS_OK;
    if (strcmp(text, "none") == 0) {
        *bytes = -1;
        return VDBS_OK;
    }
    return vdbs_memory_parse("--max-memory", text, bytes, err);
}

void vdbs_options_json_memory(cJSON *j, int64_t limit, int64_t baseline,
                              const vdbs_memory_estimate *estimate, const char *const stages[],
                              const int64_t peaks[], int stage_count, int per_stage)
{
    cJSON *m = cJSON_AddObjectToObject(j, "memory");
    if (limit > 0)
        cJSON_AddNumberToObject(m, "limit_bytes", (double)limit);
    else
        cJSON_AddNullToObject(m, "limit_bytes");
    cJSON_AddNumberToObject(m, "baseline_bytes", (double)baseline);
    cJSON_AddNumberToObject(m, "estimate_bytes", (double)vdbs_memory_total(estimate));
    cJSON *parts = cJSON_AddObjectToObject(m, "estimate");
    for (int i = 0; i < estimate->count; ++i)
        cJSON_AddNumberToObject(parts, estimate->part[i].name, (double)estimate->part[i].bytes);
    cJSON *peak = cJSON_AddObjectToObject(m, "peak_bytes");
    for (int i = 0; i < stage_count; ++i)
        cJSON_AddNumberToObject(peak, stages[i], (double)peaks[i]);
    cJSON_AddBoolToObject(m, "peak_per_stage", per_stage);
}

cJSON *vdbs_options_json_triple(const double v[3])
{
    return cJSON_CreateDoubleArray(v, 3);
}

void vdbs_options_json_light_grids(cJSON *j, const vdbs_light_grid_stats *stats)
{
    cJSON *lg = cJSON_AddObjectToObject(j, "light_grids");
    cJSON_AddNumberToObject(lg, "cells", (double)stats->cells);
    cJSON_AddNumberToObject(lg, "columns", (double)stats->columns);
    cJSON_AddNumberToObject(lg, "columns_empty", (double)stats->columns_empty);
    cJSON_AddNumberToObject(lg, "samples_stored", (double)stats->stored);
}

/* "PX,PY,PZ:TX,TY,TZ:FOV"; up is +Y unless the view is vertical. */
vdbs_status vdbs_options_camera(const char *text, vdbs_camera *camera, vdbs_error *err)
{
    char buf[512];
    if (strlen(text) >= sizeof buf)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--camera: value too long");
    strcpy(buf, text);
    char *parts[4] = {NULL, NULL, NULL, NULL};
    int n = 0;
    char *p = buf;
    while (n < 4) {
        parts[n++] = p;
        char *colon = strchr(p, ':');
        if (!colon)
            break;
        *colon = '\0';
        p = colon + 1;
    }
    memset(camera, 0, sizeof *camera);
    if (n != 3 || vdbs_options_triple("--camera", parts[0], 0, camera->position, NULL) != VDBS_OK ||
        vdbs_options_triple("--camera", parts[1], 0, camera->target, NULL) != VDBS_OK ||
        vdbs_options_number("--camera", parts[2], &camera->fov_deg, NULL) != VDBS_OK)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--camera: expected PX,PY,PZ:TX,TY,TZ:FOV_DEG, got '%s'", text);
    if (!(camera->fov_deg > 0.0 && camera->fov_deg < 180.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--camera: the field of view must be in (0, 180) degrees, got %g",
                              camera->fov_deg);
    double f[3], len2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        f[a] = camera->target[a] - camera->position[a];
        len2 += f[a] * f[a];
    }
    if (!(len2 > 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--camera: the position equals the target");
    camera->present = 1;
    camera->up[1] = 1.0;
    /* A vertical view has no horizon to keep level: put -Z at the top of the image. */
    if (f[0] * f[0] + f[2] * f[2] <= 1e-12 * len2) {
        camera->up[1] = 0.0;
        camera->up[2] = -1.0;
    }
    return VDBS_OK;
}

vdbs_status vdbs_options_size(const char *text, int *width, int *height, vdbs_error *err)
{
    char *end = NULL;
    errno = 0;
    long w = strtol(text, &end, 10);
    if (end != text && (*end == 'x' || *end == 'X') && errno == 0) {
        const char *rest = end + 1;
        long h = strtol(rest, &end, 10);
        if (end != rest && *end == '\0' && errno == 0 && w >= 1 && w <= 16384 && h >= 1 &&
            h <= 16384 && text[0] != '-' && text[0] != '+' && rest[0] != '-' && rest[0] != '+') {
            *width = (int)w;
            *height = (int)h;
            return VDBS_OK;
        }
    }
    return vdbs_error_set(err, VDBS_ERR_INPUT,
                          "--size: expected WxH with integers in [1, 16384], got '%s'", text);
}

unsigned vdbs_options_scene_flags(const vdbs_options_args *args)
{
    unsigned set = 0;
    for (int i = 0; i < args->count; ++i) {
        const scene_flag *flag = find_scene_flag(args->args[i].option->name);
        if (flag)
            set |= flag->sets;
    }
    return set;
}

int vdbs_options_has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    if (n <= e)
        return 0;
    for (size_t i = 0; i < e; ++i)
        if (tolower((unsigned char)path[n - e + i]) != tolower((unsigned char)ext[i]))
            return 0;
    return path[n - e - 1] != '/';
}

/* The solvers' own flags, from the library's solver table. */

int vdbs_options_add_solver_flags(vdbs_arg_option *options, int count, int max)
{
    const vdbs_solver *s;
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m)
        for (int i = 0; i < s->option_count && count + 1 < max; ++i)
            options[count++] = (vdbs_arg_option){
                s->options[i].flag, s->options[i].syntax ? VDBS_ARG_VALUE : VDBS_ARG_FLAG};
    options[count] = (vdbs_arg_option){NULL, VDBS_ARG_FLAG};
    return count;
}

vdbs_status vdbs_options_solver_flag(const char *name, const char *value, vdbs_scene *scene,
                                     int *handled, vdbs_error *err)
{
    const vdbs_solver_option *o = vdbs_solver_option_by_flag(name, NULL);
    *handled = o != NULL;
    if (!o)
        return VDBS_OK;
    if (!o->syntax) /* a flag without a value selects choice 1 */
        return vdbs_solver_option_set(scene, o, name, 1, err);
    if (o->kind == VDBS_OPTION_CHOICE)
        return vdbs_solver_option_choose(scene, o, name, value, err);
    vdbs_status st;
    if (o->kind == VDBS_OPTION_NUMBER) {
        double x = 0.0;
        if ((st = vdbs_options_number(name, value, &x, err)) != VDBS_OK)
            return st;
        if (!(x > o->min && x < o->max))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected a number in (%g, %g), got %s",
                                  name, o->min, o->max, value);
        return vdbs_solver_option_set(scene, o, name, x, err);
    }
    long k = 0;
    if ((st = vdbs_options_integer(name, value, (long)o->min, (long)o->max, &k, err)) != VDBS_OK)
        return st;
    if (o->even && k % 2 != 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected an even count (%s), got %ld", name,
                              o->even, k);
    return vdbs_solver_option_set(scene, o, name, (double)k, err);
}

void vdbs_options_solver_help(void)
{
    const vdbs_solver *s;
    vdbs_command_out("\nmethods (--method):\n");
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m)
        vdbs_command_out("  %-24s %s\n", s->name, s->summary);
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m) {
        if (s->option_count == 0)
            continue;
        vdbs_command_out("\n%s options (scene file keys solver.", s->name);
        for (int i = 0; i < s->option_count; ++i)
            vdbs_command_out("%s%s", i ? ", " : "", s->options[i].key);
        vdbs_command_out("):\n");
        for (int i = 0; i < s->option_count; ++i) {
            char text[1024];
            vdbs_solver_option_help(&s->options[i], text, sizeof text);
            vdbs_command_out("%s", text);
        }
    }
}

int vdbs_command_run_options(const char *command, const vdbs_options_args *args)
{
    const char *progress = vdbs_options_value(args, "--progress");
    if (progress && strcmp(progress, "auto") != 0) {
        static const struct {
            const char *name;
            vdbs_progress_style style;
        } styles[] = {{"plain", VDBS_PROGRESS_PLAIN},
                      {"json", VDBS_PROGRESS_JSON},
                      {"none", VDBS_PROGRESS_NONE}};
        size_t i = 0;
        while (i < sizeof styles / sizeof styles[0] && strcmp(progress, styles[i].name) != 0)
            ++i;
        if (i == sizeof styles / sizeof styles[0])
            return vdbs_command_fail(command, VDBS_EXIT_USAGE,
                                     "--progress: expected auto, plain, json or none");
        vdbs_command_set_progress(styles[i].style);
    }
    const char *threads = vdbs_options_value(args, "--threads");
    if (threads) {
        long n = 0;
        vdbs_error err;
        if (vdbs_options_integer("--threads", threads, 1, 4096, &n, &err) != VDBS_OK)
            return vdbs_command_fail(command, VDBS_EXIT_USAGE, err.message);
        vdbs_command_set_threads((int)n);
    }
    return VDBS_EXIT_OK;
}
