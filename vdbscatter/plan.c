#include "vdbscatter/plan.h"

#include <cjson/cJSON.h>
#include <lapacke.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"
#include "vdbscatter/advice.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/solver.h"

/* The calibration set, measured (bench/bench_calibrate.py). */
typedef struct plan_scene {
    const char *name;
    double mean_depth, albedo, g, ms_to_ss, sky_share, point_share, active_voxels;
} plan_scene;

typedef struct plan_measure {
    const char *scene;
    const char *method;
    int quality;
    double error;    /* image relative RMSE against the reference, its noise removed */
    double error_se; /* its standard error */
} plan_measure;

#include "plan_table.h"

/* Both tables end with a zeroed row (a table may be empty). */

/* Sky ordinates the measurement resolves a sky into. */
#define PLAN_SKY_ORDINATES 64
/* A light is left out when its power share is below this fraction of the tolerance. */
#define PLAN_SKIP_FRACTION 0.125
/* The error model's floors, in log error: a measurement's own noise (the bake is
 * deterministic, the reference's noise is removed) and the spread across scenes of a method
 * measured on one scene only. */
#define PLAN_NOISE_FLOOR 0.01
#define PLAN_PRIOR_FLOOR 0.1
/* Calibration scenes the error model holds at most. */
#define PLAN_MAX_SCENES 32
/* Measured single-scattering error over the multiple-scattering share ms / (ms + ss): 0.48
 * (the sky-lit cloud) to 1.25 (the smoke) on the calibration set, the sparse dragon aside
 * (its picture is mostly background). */
#define PLAN_SINGLE_FLOOR 0.5
/* The least multiply scattered share the error model divides by. */
#define PLAN_MIN_SHARE 1e-3

static double mean3(const double v[3])
{
    return (fabs(v[0]) + fabs(v[1]) + fabs(v[2])) / 3.0;
}

/* Area of the world box [lo, hi] projected along unit direction d. */
static double projected_area(const double lo[3], const double hi[3], const double d[3])
{
    const double e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    return fabs(d[0]) * e[1] * e[2] + fabs(d[1]) * e[0] * e[2] + fabs(d[2]) * e[0] * e[1];
}

static double point_power(const double lo[3], const double hi[3], const double p[3],
                          double intensity)
{
    double c[3], to[3], r2 = 0.0;
    int inside = 1;
    for (int a = 0; a < 3; ++a) {
        inside &= p[a] >= lo[a] && p[a] <= hi[a];
        c[a] = 0.5 * (lo[a] + hi[a]);
        to[a] = c[a] - p[a];
        r2 += to[a] * to[a];
    }
    if (inside || r2 <= 0.0)
        return intensity * 4.0 * VDBS_PI;
    const double r = sqrt(r2);
    for (int a = 0; a < 3; ++a)
        to[a] /= r;
    return intensity * fmin(4.0 * VDBS_PI, projected_area(lo, hi, to) / r2);
}

vdbs_status vdbs_plan_measure(const vdbs_scene *scene, const vdbs_volume *volume,
                              vdbs_plan_features *f, vdbs_error *err)
{
    memset(f, 0, sizeof *f);
    vdbs_advice advice;
    vdbs_scene_advise(scene, volume, 1, NULL, NULL, &advice);
    f->mean_depth = advice.mean_depth;
    f->ms_to_ss = advice.ms_to_ss;
    f->albedo = mean3(scene->albedo);
    f->g = scene->g;
    f->active_voxels = (double)volume->coord_count;
    float ilo[3], ihi[3];
    vdbs_volume_support_box(volume, ilo, ihi);
    double box_voxels = 1.0, extent_voxels = 0.0;
    for (int a = 0; a < 3; ++a) {
        box_voxels *= fmax((double)ihi[a] - ilo[a], 1.0);
        extent_voxels = fmax(extent_voxels, (double)ihi[a] - ilo[a]);
    }
    f->active_fraction = fmin(f->active_voxels / box_voxels, 1.0);
    /* The mean depth is along straight rays across the volume: per voxel of its extent. */
    f->voxel_mfp = extent_voxels > 0.0 ? f->mean_depth / extent_voxels : 0.0;

    vdbs_lights_desc desc = {0};
    desc.sky_ordinates = PLAN_SKY_ORDINATES;
    vdbs_light_table table;
    vdbs_status st = vdbs_lights_build(volume, scene, &desc, &table, err);
    if (st != VDBS_OK)
        return st;
    double lo[3], hi[3];
    vdbs_volume_support_bounds(volume, lo, hi);
    double power[VDBS_MAX_LIGHTS] = {0}, sky = 0.0, env_weight = 0.0, total = 0.0;
    int direct = 0;
    for (int i = 0; i < scene->light_count; ++i) {
        const vdbs_light *l = &scene->lights[i];
        if (l->type == VDBS_LIGHT_ENV) {
            env_weight += mean3(l->color) * (l->env_map ? l->env_scale : 1.0);
            continue;
        }
        const vdbs_direct_light *d = &table.direct[direct++];
        power[i] = d->type == VDBS_LIGHT_SUN ? mean3(d->color) * projected_area(lo, hi, d->world)
                                             : point_power(lo, hi, d->world, mean3(d->color));
    }
    double sum_l = 0.0, sum_l2 = 0.0, sum_w = 0.0;
    for (int k = 0; k < table.ordinate_count; ++k) {
        const vdbs_sky_ordinate *o = &table.ordinates[k];
        const double l = mean3(o->radiance);
        sky += l * o->weight * projected_area(lo, hi, o->world);
        sum_l += l * o->weight;
        sum_l2 += l * l * o->weight;
        sum_w += o->weight;
    }
    if (sum_w > 0.0 && sum_l > 0.0) {
        const double m = sum_l / sum_w;
        f->sky_variation = sqrt(fmax(sum_l2 / sum_w - m * m, 0.0)) / m;
    }
    vdbs_lights_free(&table);
    /* The sky's power goes to the env lights by their colour (and scale). */
    for (int i = 0; i < scene->light_count; ++i) {
        const vdbs_light *l = &scene->lights[i];
        if (l->type == VDBS_LIGHT_ENV && env_weight > 0.0)
            power[i] = sky * mean3(l->color) * (l->env_map ? l->env_scale : 1.0) / env_weight;
        total += power[i];
    }
    f->light_count = scene->light_count;
    for (int i = 0; i < scene->light_count; ++i) {
        f->light_share[i] = total > 0.0 ? power[i] / total : 0.0;
        if (scene->lights[i].type == VDBS_LIGHT_ENV)
            f->sky_share += f->light_share[i];
        else if (scene->lights[i].type == VDBS_LIGHT_POINT)
            f->point_share += f->light_share[i];
    }
    return VDBS_OK;
}

/* Squared distance in the planner's feature space: a decade of optical depth, of
 * 1 - albedo counts as two units, of active voxels as one; g by 0.3; light shares by 0.15
 * (the cloud under a sun and sky and under a sky alone differ 3x in error). */
static double distance2(const vdbs_plan_features *f, const plan_scene *s)
{
    const double d[6] = {
        2.0 * log10(fmax(f->mean_depth, 1e-3) / fmax(s->mean_depth, 1e-3)),
        2.0 * log10(fmax(1.0 - f->albedo, 1e-3) / fmax(1.0 - s->albedo, 1e-3)),
        (f->g - s->g) / 0.3,
        (f->sky_share - s->sky_share) / 0.15,
        (f->point_share - s->point_share) / 0.15,
        1.0 * log10(fmax(f->active_voxels, 1.0) / fmax(s->active_voxels, 1.0)),
    };
    double sum = 0.0;
    for (int i = 0; i < 6; ++i)
        sum += d[i] * d[i];
    return sum;
}

static vdbs_plan_features scene_features(const plan_scene *s)
{
    vdbs_plan_features f = {
        .mean_depth = s->mean_depth,
        .albedo = s->albedo,
        .g = s->g,
        .ms_to_ss = s->ms_to_ss,
        .active_voxels = s->active_voxels,
        .sky_share = s->sky_share,
        .point_share = s->point_share,
    };
    return f;
}

/* The multiply scattered share of the light, ms / (ms + ss), floored: what every method's error
 * scales with first (the prior mean of predict's regression). */
static double ms_share(double ms_to_ss)
{
    return fmax(ms_to_ss / (1.0 + ms_to_ss), PLAN_MIN_SHARE);
}

static const plan_scene *scene_named(const char *name)
{
    for (size_t i = 0; plan_scenes[i].name; ++i)
        if (strcmp(plan_scenes[i].name, name) == 0)
            return &plan_scenes[i];
    return NULL;
}

/* A Gaussian process over the calibration scenes that measured (method, quality), in log
 * error: its prior mean and variance are those scenes' mean and spread, its covariance
 * decays as exp(-d^2 / 2) with the distance above, and each measurement carries its own
 * noise. The prediction is the posterior mean plus one posterior standard deviation: at a
 * calibration scene, its measurement; far from all of them, the method's mean error across
 * scenes raised by its spread across scenes. 0 when no scene measured it (or every one that
 * did is left out); *spread: the posterior standard deviation of log error. */
static int predict(const vdbs_plan_features *f, const char *method, int quality,
                   const char *leave_out, double *error, double *spread)
{
    const plan_scene *at[PLAN_MAX_SCENES];
    double y[PLAN_MAX_SCENES], noise[PLAN_MAX_SCENES];
    int n = 0;
    for (size_t i = 0; plan_measures[i].scene && n < PLAN_MAX_SCENES; ++i) {
        const plan_measure *m = &plan_measures[i];
        const plan_scene *s = scene_named(m->scene);
        if (!s || m->quality != quality || strcmp(m->method, method) != 0 || !(m->error > 0.0) ||
            (leave_out && strcmp(leave_out, m->scene) == 0))
            continue;
        at[n] = s;
        y[n] = log(m->error / ms_share(s->ms_to_ss));
        noise[n] = fmax(m->error_se / m->error, PLAN_NOISE_FLOOR);
        ++n;
    }
    if (n == 0)
        return 0;
    double mean = 0.0, var = 0.0;
    for (int i = 0; i < n; ++i)
        mean += y[i] / n;
    for (int i = 0; i < n; ++i)
        var += n > 1 ? (y[i] - mean) * (y[i] - mean) / (n - 1) : 0.0;
    var = fmax(var, PLAN_PRIOR_FLOOR * PLAN_PRIOR_FLOOR);
    /* K (row-major, SPD) and two right-hand sides: y - mean and k(x, f). */
    double K[PLAN_MAX_SCENES * PLAN_MAX_SCENES], rhs[PLAN_MAX_SCENES * 2], k[PLAN_MAX_SCENES];
    for (int i = 0; i < n; ++i) {
        const vdbs_plan_features fi = scene_features(at[i]);
        for (int j = 0; j < n; ++j)
            K[i * n + j] =
                var * exp(-0.5 * distance2(&fi, at[j])) + (i == j ? noise[i] * noise[i] : 0.0);
        k[i] = var * exp(-0.5 * distance2(f, at[i]));
        rhs[2 * i] = y[i] - mean;
        rhs[2 * i + 1] = k[i];
    }
    if (LAPACKE_dposv(LAPACK_ROW_MAJOR, 'U', n, 2, K, n, rhs, 2) != 0)
        return 0; /* not positive definite: cannot happen with the noise on the diagonal */
    double post_mean = mean, post_var = var;
    for (int i = 0; i < n; ++i) {
        post_mean += k[i] * rhs[2 * i];
        post_var -= k[i] * rhs[2 * i + 1];
    }
    *spread = sqrt(fmax(post_var, 0.0));
    *error = exp(post_mean + *spread) * ms_share(f->ms_to_ss);
    /* Single scattering leaves out the multiply scattered light: its error is at least
     * PLAN_SINGLE_FLOOR of that share (the calibration set's lower envelope), whatever a
     * scene seen mostly against its background taught the regression. */
    if (strcmp(method, "single") == 0)
        *error = fmax(*error, PLAN_SINGLE_FLOOR * f->ms_to_ss / (1.0 + f->ms_to_ss));
    return 1;
}

/* Cost from the solver entry's own hint (measured on a quiet machine, bench/cost.md): the
 * calibration's timings share two cores with everything else. */
static double predict_seconds(const vdbs_solver *solver, int quality, const vdbs_plan_features *f)
{
    return solver->cost_fixed[quality] + solver->cost[quality] * f->active_voxels * 1e-6;
}

vdbs_status vdbs_plan_make(const vdbs_plan_features *f, const vdbs_plan_desc *desc, vdbs_plan *plan,
                           vdbs_error *err)
{
    memset(plan, 0, sizeof *plan);
    if (!(desc->tolerance >= 0.0 && desc->tolerance < 1.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--tolerance: expected 0 < E < 1, got %g",
                              desc->tolerance);
    const double tolerance = desc->tolerance > 0.0 ? desc->tolerance : 0.1;
    const char *leave_out = desc->leave_out;
    if (leave_out && !scene_named(leave_out)) {
        char names[512] = "";
        for (size_t i = 0; plan_scenes[i].name; ++i)
            snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", i ? ", " : "",
                     plan_scenes[i].name);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--calibration-leave-out: '%s' is not a calibration scene (%s)",
                              leave_out, names);
    }
    plan->tolerance = tolerance;
    double best_d = INFINITY;
    for (size_t i = 0; plan_scenes[i].name; ++i) {
        if (leave_out && strcmp(leave_out, plan_scenes[i].name) == 0)
            continue;
        plan->calibration_scenes++;
        const double d = distance2(f, &plan_scenes[i]);
        if (d < best_d) {
            best_d = d;
            snprintf(plan->nearest, sizeof plan->nearest, "%s", plan_scenes[i].name);
        }
    }
    /* Lights too weak to matter, never all of them. */
    int kept = f->light_count;
    for (int i = 0; i < f->light_count; ++i)
        if (f->light_share[i] < PLAN_SKIP_FRACTION * tolerance && kept > 1) {
            plan->skip[i] = 1;
            plan->skipped++;
            plan->skipped_share += f->light_share[i];
            --kept;
        }
    for (int k = 0;; ++k) {
        const vdbs_solver *s = vdbs_solver_at(k);
        if (!s)
            break;
        for (int q = 0; q < VDBS_QUALITY_COUNT; ++q) {
            vdbs_plan_candidate c = {s->name, q, 0.0, 0.0, 0.0};
            if (plan->candidate_count == VDBS_PLAN_MAX_CANDIDATES ||
                !predict(f, s->name, q, leave_out, &c.error, &c.spread))
                continue;
            c.seconds = predict_seconds(s, q, f);
            c.error += plan->skipped_share; /* what the left-out lights would have added */
            plan->candidates[plan->candidate_count++] = c;
        }
    }
    /* Without a table (a build before any calibration) nothing is reachable. */
    const vdbs_plan_candidate none = {"svd", 0, INFINITY, 0.0, 0.0};
    const vdbs_plan_candidate *best = plan->candidate_count ? NULL : &none, *cheapest = NULL;
    for (int i = 0; i < plan->candidate_count; ++i) {
        const vdbs_plan_candidate *c = &plan->candidates[i];
        if (!best || c->error < best->error)
            best = c;
        if (c->error <= tolerance && (!cheapest || c->seconds < cheapest->seconds))
            cheapest = c;
    }
    plan->reachable = cheapest != NULL;
    plan->chosen = cheapest ? *cheapest : *best;
    return VDBS_OK;
}

vdbs_status vdbs_plan_apply(const vdbs_plan *plan, vdbs_scene *scene, vdbs_error *err)
{
    int count;
    const vdbs_quality *q = vdbs_quality_list(&count);
    vdbs_status st = vdbs_scene_set_method(scene, "--method auto", plan->chosen.method, err);
    if (st == VDBS_OK)
        st = vdbs_scene_set_quality(scene, "--method auto", q[plan->chosen.quality].name, err);
    if (st != VDBS_OK || plan->skipped == 0)
        return st;
    vdbs_scene *kept = malloc(sizeof *kept);
    if (!kept)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    *kept = *scene;
    /* The kept lights in order; an env map keeps its path. */
    vdbs_scene_clear_lights(kept);
    for (int i = 0; i < scene->light_count; ++i)
        if (!plan->skip[i]) {
            vdbs_light l = scene->lights[i];
            const char *file = vdbs_light_env_file(scene, &scene->lights[i]);
            l.env_map = 0;
            kept->lights[kept->light_count] = l;
            if (file && (st = vdbs_light_set_env_file(kept, &kept->lights[kept->light_count], file,
                                                      err)) != VDBS_OK) {
                free(kept);
                return st;
            }
            kept->light_count++;
        }
    *scene = *kept;
    free(kept);
    return VDBS_OK;
}

char *vdbs_plan_json(const vdbs_plan *plan, const vdbs_plan_features *f)
{
    int count;
    const vdbs_quality *q = vdbs_quality_list(&count);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "tolerance", plan->tolerance);
    cJSON_AddBoolToObject(o, "reachable", plan->reachable);
    cJSON_AddStringToObject(o, "method", plan->chosen.method);
    cJSON_AddStringToObject(o, "quality", q[plan->chosen.quality].name);
    cJSON_AddNumberToObject(o, "predicted_error", plan->chosen.error);
    cJSON_AddNumberToObject(o, "predicted_seconds", plan->chosen.seconds);
    cJSON *skip = cJSON_AddArrayToObject(o, "skipped_lights");
    for (int i = 0; i < f->light_count; ++i)
        if (plan->skip[i])
            cJSON_AddItemToArray(skip, cJSON_CreateNumber(i));
    cJSON_AddStringToObject(o, "nearest_calibration_scene", plan->nearest);
    cJSON_AddNumberToObject(o, "calibration_scenes", plan->calibration_scenes);
    cJSON *feat = cJSON_AddObjectToObject(o, "features");
    cJSON_AddNumberToObject(feat, "mean_depth", f->mean_depth);
    cJSON_AddNumberToObject(feat, "albedo", f->albedo);
    cJSON_AddNumberToObject(feat, "g", f->g);
    cJSON_AddNumberToObject(feat, "ms_to_ss", f->ms_to_ss);
    cJSON_AddNumberToObject(feat, "active_voxels", f->active_voxels);
    cJSON_AddNumberToObject(feat, "active_fraction", f->active_fraction);
    cJSON_AddNumberToObject(feat, "voxel_mfp", f->voxel_mfp);
    cJSON_AddNumberToObject(feat, "sky_share", f->sky_share);
    cJSON_AddNumberToObject(feat, "point_share", f->point_share);
    cJSON_AddNumberToObject(feat, "sky_variation", f->sky_variation);
    cJSON_AddItemToObject(feat, "light_share",
                          cJSON_CreateDoubleArray(f->light_share, f->light_count));
    cJSON *cands = cJSON_AddArrayToObject(o, "candidates");
    for (int i = 0; i < plan->candidate_count; ++i) {
        const vdbs_plan_candidate *c = &plan->candidates[i];
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "method", c->method);
        cJSON_AddStringToObject(e, "quality", q[c->quality].name);
        cJSON_AddNumberToObject(e, "predicted_error", c->error);
        cJSON_AddNumberToObject(e, "predicted_seconds", c->seconds);
        cJSON_AddNumberToObject(e, "log_error_sd", c->spread);
        cJSON_AddItemToArray(cands, e);
    }
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return text;
}
