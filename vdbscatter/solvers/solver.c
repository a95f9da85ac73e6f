#include "vdbscatter/solver.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The table: one line per solver; each entry is defined in the solver's own file. */
extern const vdbs_solver vdbs_solver_single, vdbs_solver_pop, vdbs_solver_fld, vdbs_solver_svd,
    vdbs_solver_inet;
static const vdbs_solver *const table[] = {&vdbs_solver_single, &vdbs_solver_pop, &vdbs_solver_fld,
                                           &vdbs_solver_svd, &vdbs_solver_inet};

#define TABLE_COUNT ((int)(sizeof table / sizeof table[0]))
#define REGISTERED_MAX 8

/* Solvers from outside the library, after the table's (vdbs_solver_register). */
static const vdbs_solver *registered[REGISTERED_MAX];
static int registered_count;

const vdbs_solver *vdbs_solver_at(int index)
{
    if (index < 0)
        return NULL;
    if (index < TABLE_COUNT)
        return table[index];
    index -= TABLE_COUNT;
    return index < registered_count ? registered[index] : NULL;
}

const vdbs_solver *vdbs_solver_find(const char *name)
{
    const vdbs_solver *s;
    for (int m = 0; name && (s = vdbs_solver_at(m)) != NULL; ++m)
        if (strcmp(name, s->name) == 0)
            return s;
    return NULL;
}

void vdbs_solver_names(char *buf, size_t size)
{
    if (size == 0)
        return;
    buf[0] = '\0';
    const vdbs_solver *s;
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m) {
        if (m > 0)
            strncat(buf, ", ", size - strlen(buf) - 1);
        strncat(buf, s->name, size - strlen(buf) - 1);
    }
}

/* Finds the option whose key (by_flag 0) or flag (1) is `name` over every solver. */
static const vdbs_solver_option *option_find(const char *name, int by_flag,
                                             const vdbs_solver **solver)
{
    const vdbs_solver *s;
    for (int m = 0; name && (s = vdbs_solver_at(m)) != NULL; ++m)
        for (int i = 0; i < s->option_count; ++i)
            if (strcmp(name, by_flag ? s->options[i].flag : s->options[i].key) == 0) {
                if (solver)
                    *solver = s;
                return &s->options[i];
            }
    return NULL;
}

const vdbs_solver_option *vdbs_solver_option_by_key(const char *key, const vdbs_solver **solver)
{
    return option_find(key, 0, solver);
}

const vdbs_solver_option *vdbs_solver_option_by_flag(const char *flag, const vdbs_solver **solver)
{
    return option_find(flag, 1, solver);
}

vdbs_status vdbs_solver_register(const vdbs_solver *solver, vdbs_error *err)
{
    if (!solver || !solver->name || !solver->run)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "solver: an entry needs a name and a run");
    if (vdbs_solver_find(solver->name))
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "solver %s: the name is taken", solver->name);
    if (solver->stats_size > VDBS_SOLVER_STATS_MAX)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "solver %s: stats of %zu bytes (at most %d)",
                              solver->name, solver->stats_size, VDBS_SOLVER_STATS_MAX);
    for (int i = 0; i < solver->option_count; ++i)
        if (vdbs_solver_option_by_key(solver->options[i].key, NULL) ||
            vdbs_solver_option_by_flag(solver->options[i].flag, NULL))
            return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                                  "solver %s: option %s (%s) is taken by another solver",
                                  solver->name, solver->options[i].key, solver->options[i].flag);
    if (registered_count == REGISTERED_MAX)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "solver %s: no room (at most %d)",
                              solver->name, REGISTERED_MAX);
    registered[registered_count++] = solver;
    return VDBS_OK;
}

/* ---- options ---- */

double vdbs_solver_option_value(const vdbs_scene *scene, const vdbs_solver_option *option,
                                const vdbs_quality *quality)
{
    const double v = vdbs_scene_solver_value(scene, option->key);
    if (v != 0.0 || option->kind == VDBS_OPTION_CHOICE)
        return v;
    return option->preset[vdbs_quality_level(quality ? quality->name : NULL)];
}

static int choice_count(const vdbs_solver_option *option)
{
    int n = 0;
    while (option->choices && option->choices[n])
        ++n;
    return n;
}

/* "a or b", "a, b or c". */
static void choice_list(const vdbs_solver_option *option, char *buf, size_t size)
{
    const int n = choice_count(option);
    buf[0] = '\0';
    for (int i = 0; i < n; ++i) {
        size_t len = strlen(buf);
        snprintf(buf + len, size - len, "%s%s", i == 0 ? "" : (i == n - 1 ? " or " : ", "),
                 option->choices[i]);
    }
}

/* The range check of one value; what names it. */
static vdbs_status check_value(const vdbs_solver_option *o, const char *what, double v,
                               vdbs_error *err)
{
    switch (o->kind) {
    case VDBS_OPTION_CHOICE:
        if (v < 0 || v >= choice_count(o) || v != floor(v)) {
            char list[128];
            choice_list(o, list, sizeof list);
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: choice %g out of range (%s)", what, v,
                                  list);
        }
        return VDBS_OK;
    case VDBS_OPTION_NUMBER: /* 0 is the default */
        if (!(isfinite(v) && (v == 0.0 || (v > o->min && v < o->max))))
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "%s: must be in [%g, %g) (0: the default), got %g", what, o->min,
                                  o->max, v);
        return VDBS_OK;
    case VDBS_OPTION_INT:
        if (v != 0.0 && !(v >= o->min && v <= o->max && v == floor(v)))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: must be in %g..%g, got %g", what,
                                  o->min, o->max, v);
        if (o->even && fmod(v, 2.0) != 0.0)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: %g is odd (%s needs an even count)",
                                  what, v, o->even);
        return VDBS_OK;
    }
    return VDBS_OK;
}

vdbs_status vdbs_solver_option_set(vdbs_scene *scene, const vdbs_solver_option *option,
                                   const char *what, double value, vdbs_error *err)
{
    vdbs_status st = check_value(option, what, value, err);
    return st != VDBS_OK ? st : vdbs_scene_solver_store(scene, option->key, value, err);
}

vdbs_status vdbs_solver_set(vdbs_scene *scene, const char *key, double value, vdbs_error *err)
{
    char what[64];
    snprintf(what, sizeof what, "solver.%s", key);
    const vdbs_solver_option *o = vdbs_solver_option_by_key(key, NULL);
    if (!o)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: no solver has this option", what);
    return vdbs_solver_option_set(scene, o, what, value, err);
}

vdbs_status vdbs_solver_option_choose(vdbs_scene *scene, const vdbs_solver_option *option,
                                      const char *what, const char *name, vdbs_error *err)
{
    const int n = choice_count(option);
    for (int i = 0; i < n; ++i)
        if (name && strcmp(name, option->choices[i]) == 0)
            return vdbs_scene_solver_store(scene, option->key, i, err);
    char list[128];
    choice_list(option, list, sizeof list);
    return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: unknown %s \"%s\" (expected %s)", what,
                          option->noun ? option->noun : "value", name ? name : "", list);
}

const char *vdbs_solver_option_choice(const vdbs_scene *scene, const vdbs_solver_option *option)
{
    const int i = (int)vdbs_scene_solver_value(scene, option->key);
    return i >= 0 && i < choice_count(option) ? option->choices[i] : "";
}

vdbs_status vdbs_solver_options_check(const vdbs_scene *scene, const char *prefix, vdbs_error *err)
{
    for (int i = 0; i < scene->solver_setting_count; ++i) {
        const vdbs_solver_setting *set = &scene->solver_settings[i];
        const vdbs_solver_option *o = vdbs_solver_option_by_key(set->key, NULL);
        char what[160];
        snprintf(what, sizeof what, "%ssolver.%s", prefix, set->key);
        if (!o)
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: no solver has this option", what);
        vdbs_status st = check_value(o, what, set->value, err);
        if (st != VDBS_OK)
            return st;
    }
    const vdbs_solver *s;
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m) {
        vdbs_status st = s->validate ? s->validate(scene, prefix, err) : VDBS_OK;
        if (st != VDBS_OK)
            return st;
    }
    return VDBS_OK;
}

void vdbs_solver_option_help(const vdbs_solver_option *option, char *buf, size_t size)
{
    char head[64];
    snprintf(head, sizeof head, "  %s%s%s", option->flag, option->syntax ? " " : "",
             option->syntax ? option->syntax : "");
    size_t len = (size_t)snprintf(buf, size, "%-27s", head);
    if (strlen(head) >= 27)
        len = (size_t)snprintf(buf, size, "%s\n%27s", head, "");
    for (const char *p = option->help; p && *p && len + 30 < size; ++p) {
        if (*p == '\n')
            len += (size_t)snprintf(buf + len, size - len, "\n%27s", "");
        else
            buf[len++] = *p;
    }
    if (len + 2 <= size) {
        buf[len++] = '\n';
        buf[len] = '\0';
    } else if (size > 0) {
        buf[size - 1] = '\0';
    }
}

/* ---- report ---- */

static double field_number(const vdbs_report_field *f, const void *stats)
{
    const unsigned char *at = (const unsigned char *)stats + f->offset;
    int i;
    int64_t l;
    double d;
    switch (f->kind) {
    case VDBS_REPORT_INT64:
        memcpy(&l, at, sizeof l);
        return (double)l;
    case VDBS_REPORT_DOUBLE:
    case VDBS_REPORT_SECONDS:
        memcpy(&d, at, sizeof d);
        return d;
    default:
        memcpy(&i, at, sizeof i);
        return i;
    }
}

void vdbs_solver_report_json(const vdbs_solver *solver, const vdbs_scene *scene, const void *stats,
                             cJSON *seconds, cJSON *report)
{
    if (solver->report_count == 0)
        return;
    cJSON *block = cJSON_AddObjectToObject(report, solver->name);
    for (int i = 0; i < solver->report_count; ++i) {
        const vdbs_report_field *f = &solver->report[i];
        const double v = field_number(f, stats);
        if (f->kind == VDBS_REPORT_SECONDS) {
            char key[64];
            snprintf(key, sizeof key, "%s_%s", solver->name, f->key);
            cJSON_AddNumberToObject(seconds, key, v);
        } else if (f->kind == VDBS_REPORT_BOOL) {
            cJSON_AddBoolToObject(block, f->key, v != 0.0);
        } else if (f->kind == VDBS_REPORT_ON_OFF) {
            cJSON_AddStringToObject(block, f->key, v != 0.0 ? "on" : "off");
        } else {
            cJSON_AddNumberToObject(block, f->key, v);
        }
    }
    for (int i = 0; i < solver->option_count; ++i) {
        const vdbs_solver_option *o = &solver->options[i];
        if (o->report_key && o->kind == VDBS_OPTION_CHOICE)
            cJSON_AddStringToObject(block, o->report_key, vdbs_solver_option_choice(scene, o));
        else if (o->report_key)
            cJSON_AddNumberToObject(block, o->report_key, vdbs_scene_solver_value(scene, o->key));
    }
}

int vdbs_solver_state_grids(const char *prefix, int count, float *const *values, char (**names)[24],
                            vdbio_vec3_grid *grids, int max)
{
    if (!grids)
        return count;
    const int n = count < max ? count : max;
    if (!*names && n > 0 && !(*names = calloc((size_t)n, sizeof **names)))
        return -1;
    for (int k = 0; k < n; ++k) {
        snprintf((*names)[k], sizeof(*names)[k], "%s%04d", prefix, k);
        grids[k] = (vdbio_vec3_grid){(*names)[k], values[k]};
    }
    return n;
}

const vdbs_quality *vdbs_solver_quality(const vdbs_solver *solver, const vdbs_quality *quality)
{
    const vdbs_quality *stop =
        solver && solver->ladder_stop && quality ? vdbs_quality_find(solver->ladder_stop) : NULL;
    return stop && vdbs_quality_level(quality->name) > vdbs_quality_level(stop->name) ? stop
                                                                                      : quality;
}

int vdbs_solver_sky_directions(const vdbs_solver *solver, const vdbs_scene *scene,
                               const vdbs_quality *quality)
{
    if (scene->sky_directions > 0)
        return scene->sky_directions;
    const int level = vdbs_quality_level(quality->name);
    if (solver && solver->sky_directions[level] > 0)
        return solver->sky_directions[level];
    return quality->sky_directions;
}
