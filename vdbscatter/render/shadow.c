#include "vdbscatter/shadow.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_shadow.h"

vdbs_status vdbs_shadow_sun_frame_fit(const double direction[3], const double box_lo[3],
                                      const double box_hi[3], vdbs_shadow_sun_frame *f,
                                      vdbs_error *err)
{
    double n = sqrt(direction[0] * direction[0] + direction[1] * direction[1] +
                    direction[2] * direction[2]);
    if (!(n > 0.0) || !isfinite(n))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "shadow map: zero sun direction");
    double centre[3], radius2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        if (!(box_hi[a] > box_lo[a]))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "shadow map: empty box");
        f->w[a] = direction[a] / n;
        centre[a] = 0.5 * (box_lo[a] + box_hi[a]);
        radius2 += 0.25 * (box_hi[a] - box_lo[a]) * (box_hi[a] - box_lo[a]);
    }
    double radius = sqrt(radius2);
    /* u: the axis least aligned with w, made orthogonal; v = w x u. */
    int least = fabs(f->w[0]) <= fabs(f->w[1]) && fabs(f->w[0]) <= fabs(f->w[2]) ? 0
                : fabs(f->w[1]) <= fabs(f->w[2])                                 ? 1
                                                                                 : 2;
    double e[3] = {0.0, 0.0, 0.0};
    e[least] = 1.0;
    double dot = f->w[least];
    double len = 0.0;
    for (int a = 0; a < 3; ++a) {
        f->u[a] = e[a] - dot * f->w[a];
        len += f->u[a] * f->u[a];
    }
    len = sqrt(len);
    for (int a = 0; a < 3; ++a)
        f->u[a] /= len;
    f->v[0] = f->w[1] * f->u[2] - f->w[2] * f->u[1];
    f->v[1] = f->w[2] * f->u[0] - f->w[0] * f->u[2];
    f->v[2] = f->w[0] * f->u[1] - f->w[1] * f->u[0];
    for (int a = 0; a < 3; ++a)
        f->origin[a] = centre[a] - radius * f->w[a];
    f->half = radius;
    f->range = 2.0 * radius;
    return VDBS_OK;
}

vdbs_status vdbs_shadow_table_init(vdbs_shadow_table *t, int lights, vdbs_error *err)
{
    memset(t, 0, sizeof *t);
    t->floats = VS_SHADOW_OFF_ENTRIES + (size_t)(lights > 0 ? lights : 0) * VS_SHADOW_ENTRY_SIZE;
    t->data = calloc(t->floats, sizeof *t->data);
    if (!t->data)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for shadow maps");
    t->lights = lights > 0 ? lights : 0;
    t->data[VS_SHADOW_OFF_COUNT] = (float)t->lights;
    return VDBS_OK;
}

void vdbs_shadow_table_free(vdbs_shadow_table *t)
{
    free(t->data);
    memset(t, 0, sizeof *t);
}

/* Appends `count` texels and fills entry k's common fields into *entry. */
static vdbs_status add_entry(vdbs_shadow_table *t, int k, int kind, int res, const float *texels,
                             size_t count, double bias, float **entry, vdbs_error *err)
{
    if (k < 0 || k >= t->lights || res < 1)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "shadow map %d of %d (res %d)", k, t->lights,
                              res);
    /* The float offsets must stay exact in a float. */
    if (t->floats + count > (1u << 24))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "shadow maps beyond 2^24 texels");
    float *grown = realloc(t->data, sizeof *grown * (t->floats + count));
    if (!grown)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for shadow maps");
    t->data = grown;
    memcpy(t->data + t->floats, texels, sizeof *texels * count);
    float *e = t->data + VS_SHADOW_OFF_ENTRIES + (size_t)k * VS_SHADOW_ENTRY_SIZE;
    e[VS_SHADOW_KIND] = (float)kind;
    e[VS_SHADOW_RES] = (float)res;
    e[VS_SHADOW_TEXELS] = (float)t->floats;
    e[VS_SHADOW_BIAS] = (float)bias;
    t->floats += count;
    *entry = e;
    return VDBS_OK;
}

vdbs_status vdbs_shadow_table_set_sun(vdbs_shadow_table *t, int k, const vdbs_shadow_sun_frame *f,
                                      int res, const float *depths, double bias, vdbs_error *err)
{
    float *e = NULL;
    vdbs_status st =
        add_entry(t, k, VS_SHADOW_SUN, res, depths, (size_t)res * (size_t)res, bias, &e, err);
    if (st != VDBS_OK)
        return st;
    for (int a = 0; a < 3; ++a) {
        e[VS_SHADOW_ORIGIN + a] = (float)f->origin[a];
        e[VS_SHADOW_U + a] = (float)f->u[a];
        e[VS_SHADOW_V + a] = (float)f->v[a];
        e[VS_SHADOW_W + a] = (float)f->w[a];
    }
    e[VS_SHADOW_HALF] = (float)f->half;
    return VDBS_OK;
}

vdbs_status vdbs_shadow_table_set_cube(vdbs_shadow_table *t, int k, const double position[3],
                                       int res, const float *distances, double bias,
                                       vdbs_error *err)
{
    float *e = NULL;
    vdbs_status st = add_entry(t, k, VS_SHADOW_CUBE, res, distances, 6u * (size_t)res * (size_t)res,
                               bias, &e, err);
    if (st != VDBS_OK)
        return st;
    for (int a = 0; a < 3; ++a)
        e[VS_SHADOW_ORIGIN + a] = (float)position[a];
    return VDBS_OK;
}

float vdbs_shadow_visibility(const vdbs_shadow_table *t, int k, const double p[3])
{
    return vs_shadow_visibility(t->data, k, vs_vec3((float)p[0], (float)p[1], (float)p[2]));
}
