#include "vdbscatter/lights.h"

#include "vdbscatter/sphere.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "base/vdbs_math.h"
#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lights.h"

/* The kernels compare light types with the shader constants. */
_Static_assert(VS_LIGHT_SUN == (int)VDBS_LIGHT_SUN, "sun type");
_Static_assert(VS_LIGHT_POINT == (int)VDBS_LIGHT_POINT, "point type");
_Static_assert(VS_LIGHT_ENV == (int)VDBS_LIGHT_ENV, "env type");

void vdbs_lights_free(vdbs_light_table *table)
{
    if (!table)
        return;
    free(table->direct);
    free(table->ordinates);
    free(table->packed);
    vdbs_envmap_free(table->env);
    free(table->env);
    memset(table, 0, sizeof *table);
}

vdbs_status vdbs_lights_pack(vdbs_light_table *t, vdbs_error *err)
{
    free(t->packed);
    t->packed = NULL;
    size_t n = VS_LIGHTS_HEADER_SIZE + VS_LIGHT_STRIDE * (size_t)t->direct_count +
               VS_ORDINATE_STRIDE * (size_t)t->ordinate_count;
    float *p = calloc(n, 4 * sizeof *p);
    if (!p)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the light table");
    const double counts[3] = {t->direct_count, t->ordinate_count, t->min_distance};
    vdbs_table_put(p + 4 * VS_LIGHTS_OFF_COUNTS, counts[0], counts[1], counts[2], 0.0);
    vdbs_table_put(p + 4 * VS_LIGHTS_OFF_BACKGROUND, t->sky[0], t->sky[1], t->sky[2], 0.0);
    for (int i = 0; i < t->direct_count; ++i) {
        const vdbs_direct_light *l = &t->direct[i];
        float *e = p + 4 * (VS_LIGHTS_HEADER_SIZE + VS_LIGHT_STRIDE * (size_t)i);
        e[4 * VS_LIGHT_OFF_INDEX] = (float)l->type;
        for (int a = 0; a < 3; ++a)
            e[4 * VS_LIGHT_OFF_INDEX + 1 + a] = (float)l->index[a];
        vdbs_table_put(e + 4 * VS_LIGHT_OFF_WORLD, l->world[0], l->world[1], l->world[2], 0.0);
        vdbs_table_put(e + 4 * VS_LIGHT_OFF_COLOR, l->color[0], l->color[1], l->color[2], 0.0);
    }
    for (int k = 0; k < t->ordinate_count; ++k) {
        const vdbs_sky_ordinate *o = &t->ordinates[k];
        float *e = p + 4 * (VS_LIGHTS_HEADER_SIZE + VS_LIGHT_STRIDE * (size_t)t->direct_count +
                            VS_ORDINATE_STRIDE * (size_t)k);
        const double weighted[3] = {o->radiance[0] * o->weight, o->radiance[1] * o->weight,
                                    o->radiance[2] * o->weight};
        vdbs_table_put(e + 4 * VS_ORDINATE_OFF_INDEX, o->index[0], o->index[1], o->index[2], 0.0);
        vdbs_table_put(e + 4 * VS_ORDINATE_OFF_WORLD, o->world[0], o->world[1], o->world[2],
                       o->weight);
        vdbs_table_put(e + 4 * VS_ORDINATE_OFF_WEIGHTED, weighted[0], weighted[1], weighted[2],
                       0.0);
    }
    t->packed = p;
    t->packed_entries = n;
    return VDBS_OK;
}

/* The factor on every texel of the sky map's sampling density (NULL: none needed): the
 * importance map's value there (nearest texel of the small map), 0 on a split-off sun. */
static float *texel_weights(const vdbs_envmap *env, const vdbs_lights_desc *desc, int *sun,
                            double sun_dir[3], double sun_power[3], double *sun_omega, int *fail)
{
    *sun = 0;
    *fail = 0;
    if (!desc || (!desc->importance && !desc->split_sun))
        return NULL;
    float *w = malloc(sizeof *w * (size_t)env->width * (size_t)env->height);
    if (!w) {
        *fail = 1;
        return NULL;
    }
    for (int y = 0; y < env->height; ++y)
        for (int x = 0; x < env->width; ++x) {
            double d[3], rgb[3] = {1.0, 1.0, 1.0};
            vdbs_envmap_direction(env, x, y, d);
            if (desc->importance)
                vdbs_envmap_texel(desc->importance, d, rgb);
            w[(size_t)y * env->width + x] = (float)rgb[0];
        }
    if (desc->split_sun && desc->sky_ordinates >= 2)
        *sun = vdbs_envmap_find_sun(env, w, sun_dir, sun_power, sun_omega);
    return w;
}

/* The scene's env lights: constant colours summed into table->sky, at most one map loaded
 * into table->env; *direct counts the other lights (suns and points). On an error the
 * caller frees the table. */
static vdbs_status sky_lights(const vdbs_scene *scene, vdbs_light_table *table, int *direct,
                              vdbs_error *err)
{
    *direct = 0;
    for (int i = 0; i < scene->light_count; ++i) {
        const vdbs_light *light = &scene->lights[i];
        if (light->type != VDBS_LIGHT_ENV) {
            ++*direct;
            continue;
        }
        const char *file = vdbs_light_env_file(scene, light);
        if (light->env_map != 0 && !file[0])
            return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                                  "lights[%d]: env_map %d is not a path of this scene", i,
                                  light->env_map);
        table->has_sky = 1;
        if (!file[0]) {
            for (int c = 0; c < 3; ++c)
                table->sky[c] += light->color[c];
            continue;
        }
        if (table->env)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "%s: one environment map per scene (the other is %s)", file,
                                  table->env_file);
        table->env = calloc(1, sizeof *table->env);
        if (!table->env)
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for an env map");
        snprintf(table->env_file, sizeof table->env_file, "%s", file);
        vdbs_status st = vdbs_envmap_load(file, light->env_scale, table->env, err);
        if (st != VDBS_OK)
            return st;
    }
    return VDBS_OK;
}

/* The suns and point lights with their world and index geometry, in the scene's order. */
static vdbs_status direct_lights(const vdbs_volume *volume, const vdbs_scene *scene,
                                 vdbs_light_table *table, vdbs_error *err)
{
    for (int i = 0; i < scene->light_count; ++i) {
        const vdbs_light *light = &scene->lights[i];
        if (light->type == VDBS_LIGHT_ENV)
            continue;
        vdbs_direct_light *l = &table->direct[table->direct_count];
        l->type = light->type;
        memcpy(l->color, light->color, sizeof l->color);
        if (light->type == VDBS_LIGHT_SUN) {
            if (!vdbs_volume_sun_step(volume, light->direction, l->world, l->index))
                return vdbs_error_set(err, VDBS_ERR_INPUT, "sun %d has a zero direction", i);
        } else {
            memcpy(l->world, light->position, sizeof l->world);
            vdbs_volume_index_point(volume, light->position, l->index);
        }
        ++table->direct_count;
    }
    return VDBS_OK;
}

static void put_ordinate(const vdbs_volume *volume, vdbs_sky_ordinate *o, const double world[3])
{
    memcpy(o->world, world, sizeof o->world);
    vdbs_volume_index_vector(volume, o->world, o->index);
}

/* k sky ordinates importance-sampled from the map (a split-off sun first, with its power
 * over its solid angle), a constant env on top added to every one. Returns how many were
 * drawn, -1 when out of memory (err set). dirs has room for k. */
static int map_ordinates(const vdbs_volume *volume, const vdbs_lights_desc *desc, int k,
                         double *dirs, vdbs_light_table *table, vdbs_error *err)
{
    double *weight = calloc(k > 0 ? (size_t)k : 1, sizeof *weight);
    double *radiance = calloc(k > 0 ? 3 * (size_t)k : 1, sizeof *radiance);
    int sun = 0, fail = 0;
    double sun_dir[3], sun_power[3], sun_omega = 0.0;
    float *texel_weight =
        texel_weights(table->env, desc, &sun, sun_dir, sun_power, &sun_omega, &fail);
    int got = weight && radiance && !fail
                  ? vdbs_envmap_sample(table->env, texel_weight, k - sun, dirs + 3 * sun,
                                       weight + sun, radiance + 3 * sun, err)
                  : -1;
    free(texel_weight);
    if (got >= 0 && sun) {
        /* The split-off sun: one ordinate carrying its power over its solid angle. */
        memcpy(dirs, sun_dir, sizeof sun_dir);
        weight[0] = sun_omega;
        for (int c = 0; c < 3; ++c)
            radiance[c] = sun_power[c] / sun_omega;
        got += 1;
    }
    if (got < 0)
        vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the light table");
    for (int d = 0; d < got; ++d) {
        vdbs_sky_ordinate *o = &table->ordinates[d];
        put_ordinate(volume, o, dirs + 3 * d);
        o->weight = weight[d];
        for (int c = 0; c < 3; ++c)
            o->radiance[c] = radiance[3 * d + c] + table->sky[c];
    }
    free(weight);
    free(radiance);
    return got;
}

/* k sky ordinates of a constant sky: directions spread over the sphere, equal weights. */
static void uniform_ordinates(const vdbs_volume *volume, int k, double *dirs,
                              vdbs_light_table *table)
{
    vdbs_sphere_directions(k, dirs);
    for (int d = 0; d < k; ++d) {
        vdbs_sky_ordinate *o = &table->ordinates[d];
        put_ordinate(volume, o, dirs + 3 * d);
        o->weight = 4.0 * VDBS_PI / k;
        memcpy(o->radiance, table->sky, sizeof o->radiance);
    }
}

static vdbs_status build_table(const vdbs_volume *volume, const vdbs_scene *scene,
                               const vdbs_lights_desc *desc, vdbs_light_table *table,
                               vdbs_error *err)
{
    int direct = 0;
    vdbs_status st = sky_lights(scene, table, &direct, err);
    if (st != VDBS_OK)
        return st;
    table->min_distance = 0.5 * volume->mean_voxel_size;
    int k = table->has_sky && desc && desc->sky_ordinates > 0 ? desc->sky_ordinates : 0;
    table->direct = calloc(direct > 0 ? (size_t)direct : 1, sizeof *table->direct);
    table->ordinates = calloc(k > 0 ? (size_t)k : 1, sizeof *table->ordinates);
    double *dirs = calloc(k > 0 ? 3 * (size_t)k : 1, sizeof *dirs);
    if (!table->direct || !table->ordinates || !dirs) {
        free(dirs);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the light table");
    }
    st = direct_lights(volume, scene, table, err);
    if (st == VDBS_OK && table->env) {
        /* Importance-sampled from the map; a constant env on top adds to every ordinate. */
        k = map_ordinates(volume, desc, k, dirs, table, err);
        if (k < 0)
            st = VDBS_ERR_NOMEM;
    } else if (st == VDBS_OK) {
        uniform_ordinates(volume, k, dirs, table);
    }
    free(dirs);
    if (st != VDBS_OK)
        return st;
    table->ordinate_count = k;
    return vdbs_lights_pack(table, err);
}

vdbs_status vdbs_lights_build(const vdbs_volume *volume, const vdbs_scene *scene,
                              const vdbs_lights_desc *desc, vdbs_light_table *table,
                              vdbs_error *err)
{
    memset(table, 0, sizeof *table);
    vdbs_status st = build_table(volume, scene, desc, table, err);
    if (st != VDBS_OK)
        vdbs_lights_free(table);
    return st;
}

void vdbs_lights_arrival(const vdbs_light_table *table, int light, const double p[3],
                         double color[3], double travel[3])
{
    if (light >= table->direct_count) {
        const vdbs_sky_ordinate *o = &table->ordinates[light - table->direct_count];
        for (int a = 0; a < 3; ++a) {
            color[a] = o->radiance[a] * o->weight;
            travel[a] = -o->world[a];
        }
        return;
    }
    const vdbs_direct_light *dl = &table->direct[light];
    memcpy(color, dl->color, 3 * sizeof *color);
    if (dl->type != VDBS_LIGHT_POINT) {
        memcpy(travel, dl->world, 3 * sizeof *travel);
        return;
    }
    double d[3] = {p[0] - dl->world[0], p[1] - dl->world[1], p[2] - dl->world[2]};
    double r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double rc = fmax(r, table->min_distance);
    for (int a = 0; a < 3; ++a) {
        color[a] /= rc * rc;
        travel[a] = r > 0.0 ? d[a] / r : (a == 2 ? 1.0 : 0.0);
    }
}
