#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/tradeoff.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "vdbscatter/bake.h"
#include "vdbscatter/image.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/message.h"
#include "vdbscatter/plot.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/tempfile.h"

#define DEFAULT_REF_NOISE 0.01
#define DEFAULT_REF_SECONDS 600.0
/* The pilot reference that sizes the real one; also a point of the reference's curve. */
#define PILOT_SPP 16

void vdbs_tradeoff_measure(const float *a, const float *b, const float *b_se, long long n,
                           vdbs_tradeoff_metrics *m)
{
    double sum_d2 = 0.0, sum_b2 = 0.0, sum_se2 = 0.0, var = 0.0, sum_a = 0.0, sum_b = 0.0;
    for (long long i = 0; i < n; ++i) {
        const double d = (double)a[i] - b[i], se = b_se ? b_se[i] : 0.0;
        sum_d2 += d * d;
        sum_b2 += (double)b[i] * b[i];
        sum_se2 += se * se;
        var += 4.0 * d * d * se * se + 2.0 * se * se * se * se;
        sum_a += a[i];
        sum_b += b[i];
    }
    m->mean_ratio = sum_b > 0.0 ? sum_a / sum_b : 0.0;
    const double mse = fmax(sum_d2 - sum_se2, 0.0);
    if (!(sum_b2 > 0.0)) {
        m->relrmse = sum_d2 > 0.0 ? INFINITY : 0.0;
        m->relrmse_se = 0.0;
        return;
    }
    m->relrmse = sqrt(mse / sum_b2);
    /* d sqrt(m) = dm / (2 sqrt(m)); near 0 the error is at most sqrt of the mse's spread. */
    const double sd_mse = sqrt(var);
    m->relrmse_se = mse > sd_mse ? sd_mse / (2.0 * sqrt(mse * sum_b2)) : sqrt(sd_mse / sum_b2);
}

/* ---- the reference, cached under a key of everything that makes it ---- */

static uint64_t fnv1a(uint64_t h, const void *data, size_t size)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < size; ++i)
        h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static vdbs_status reference_key(const vdbs_tradeoff_desc *d, const char *input, int width,
                                 int height, double noise, char key[17], vdbs_error *err)
{
    /* The scene as written to a lit VDB, with the method and quality that do not change the
     * reference taken out, plus the input file's identity and the view. */
    vdbs_scene *s = malloc(sizeof *s);
    if (!s)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    *s = *d->scene;
    memset(s->method, 0, sizeof s->method);
    memset(s->quality, 0, sizeof s->quality);
    s->sky_directions = 0;
    s->solver_setting_count = 0;
    char *json = vdbs_scene_to_json(s);
    free(s);
    if (!json)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    uint64_t h = 14695981039346656037ull;
    h = fnv1a(h, json, strlen(json));
    free(json);
    struct stat st;
    if (stat(input, &st) == 0) {
        const long long id[2] = {(long long)st.st_size, (long long)st.st_mtime};
        h = fnv1a(h, id, sizeof id);
    }
    h = fnv1a(h, input, strlen(input));
    char view[512];
    const vdbs_camera *c = d->camera;
    snprintf(view, sizeof view, "%dx%d noise %.6g seed %llu", width, height, noise,
             (unsigned long long)d->seed);
    h = fnv1a(h, view, strlen(view));
    if (c && c->present) {
        snprintf(view, sizeof view, "%.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g",
                 c->position[0], c->position[1], c->position[2], c->target[0], c->target[1],
                 c->target[2], c->up[0], c->up[1], c->up[2], c->fov_deg);
        h = fnv1a(h, view, strlen(view));
    }
    snprintf(key, 17, "%016llx", (unsigned long long)h);
    return VDBS_OK;
}

typedef struct tradeoff_job {
    const vdbs_tradeoff_desc *desc;
    const char *input;
    int width, height;
    vdbs_tradeoff_report *report;
    vdbs_image reference;
} tradeoff_job;

static void job_path(const tradeoff_job *j, char *path, size_t size, const char *name)
{
    snprintf(path, size, "%s/%s", j->desc->dir, name);
}

static vdbs_status render_reference(const tradeoff_job *j, const char *path, int spp, uint64_t seed,
                                    double *seconds, vdbs_error *err)
{
    vdbs_render_desc r = {0};
    r.input = j->input;
    r.output = path;
    r.scene = j->desc->scene;
    r.mode = VDBS_RENDER_REFERENCE;
    r.camera = j->desc->camera;
    r.width = j->width;
    r.height = j->height;
    r.spp = spp;
    r.seed = seed;
    r.warn = j->desc->warn;
    r.warn_user = j->desc->warn_user;
    r.cancel = j->desc->cancel;
    r.max_memory = j->desc->max_memory;
    vdbs_render_report rep;
    vdbs_status st = vdbs_render(&r, &rep, err);
    *seconds = rep.seconds_render;
    return st;
}

static vdbs_status curve_point(tradeoff_job *j, const char *path, int spp, double seconds,
                               vdbs_error *err)
{
    vdbs_image im = {0};
    vdbs_status st = vdbs_image_read(path, &im, err);
    if (st != VDBS_OK)
        return st;
    vdbs_tradeoff_report *rep = j->report;
    vdbs_tradeoff_curve_point *p = &rep->curve[rep->curve_count++];
    vdbs_tradeoff_metrics m;
    vdbs_tradeoff_measure(im.rgb, j->reference.rgb, j->reference.se, 3ll * j->width * j->height,
                          &m);
    p->spp = spp;
    p->seconds = seconds;
    p->relrmse = m.relrmse;
    vdbs_image_free(&im);
    return VDBS_OK;
}

static vdbs_status reference_write_meta(const tradeoff_job *j, const char *path, vdbs_error *err)
{
    const vdbs_tradeoff_report *rep = j->report;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "spp", rep->reference_spp);
    cJSON_AddNumberToObject(o, "seconds", rep->reference_seconds);
    cJSON_AddNumberToObject(o, "noise", rep->reference_noise);
    cJSON *c = cJSON_AddArrayToObject(o, "curve");
    for (int i = 0; i < rep->curve_count; ++i) {
        cJSON *p = cJSON_CreateObject();
        cJSON_AddNumberToObject(p, "spp", rep->curve[i].spp);
        cJSON_AddNumberToObject(p, "seconds", rep->curve[i].seconds);
        cJSON_AddNumberToObject(p, "relrmse", rep->curve[i].relrmse);
        cJSON_AddItemToArray(c, p);
    }
    char *text = cJSON_Print(o);
    cJSON_Delete(o);
    if (!text)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    vdbs_text_file out;
    vdbs_status st = vdbs_text_begin(&out, path, err);
    if (st == VDBS_OK) {
        fputs(text, out.stream);
        st = vdbs_text_commit(&out, err);
    }
    free(text);
    return st;
}

/* 1 when the cache holds the reference (image and its metadata), read into the job. */
static int reference_from_cache(tradeoff_job *j, const char *image, const char *meta)
{
    FILE *f = fopen(meta, "r");
    if (!f)
        return 0;
    char text[8192];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    cJSON *o = cJSON_Parse(text);
    vdbs_error ignored;
    vdbs_tradeoff_report *rep = j->report;
    int ok = o && vdbs_image_read(image, &j->reference, &ignored) == VDBS_OK && j->reference.se &&
             j->reference.width == j->width && j->reference.height == j->height;
    if (ok) {
        rep->reference_spp = cJSON_GetNumberValue(cJSON_GetObjectItem(o, "spp"));
        rep->reference_seconds = cJSON_GetNumberValue(cJSON_GetObjectItem(o, "seconds"));
        rep->reference_noise = vdbs_image_noise(&j->reference);
        const cJSON *c = cJSON_GetObjectItem(o, "curve"), *p;
        cJSON_ArrayForEach(p, c)
        {
            if (rep->curve_count == VDBS_TRADEOFF_MAX_CURVE)
                break;
            vdbs_tradeoff_curve_point *q = &rep->curve[rep->curve_count++];
            q->spp = (int)cJSON_GetNumberValue(cJSON_GetObjectItem(p, "spp"));
            q->seconds = cJSON_GetNumberValue(cJSON_GetObjectItem(p, "seconds"));
            q->relrmse = cJSON_GetNumberValue(cJSON_GetObjectItem(p, "relrmse"));
        }
    } else {
        vdbs_image_free(&j->reference);
    }
    cJSON_Delete(o);
    return ok;
}

/* The pilot (PILOT_SPP) sizes the reference for the noise target within the time; the
 * curve then takes 1, 4, 64, ... spp with other seeds, up to a quarter of the reference. */
static vdbs_status make_reference(tradeoff_job *j, vdbs_progress *progress, vdbs_error *err)
{
    const vdbs_tradeoff_desc *d = j->desc;
    vdbs_tradeoff_report *rep = j->report;
    const double target = d->ref_noise > 0.0 ? d->ref_noise : DEFAULT_REF_NOISE;
    const double limit = d->ref_seconds > 0.0 ? d->ref_seconds : DEFAULT_REF_SECONDS;
    vdbs_status st = reference_key(d, j->input, j->width, j->height, target, rep->key, err);
    if (st != VDBS_OK)
        return st;
    char image[VDBS_PATH_MAX], meta[VDBS_PATH_MAX], scratch[VDBS_PATH_MAX], name[64];
    snprintf(name, sizeof name, "reference-%s.exr", rep->key);
    job_path(j, image, sizeof image, name);
    snprintf(name, sizeof name, "reference-%s.json", rep->key);
    job_path(j, meta, sizeof meta, name);
    if (reference_from_cache(j, image, meta)) {
        rep->reference_cached = 1;
        return VDBS_OK;
    }
    char pilot_path[VDBS_PATH_MAX];
    job_path(j, scratch, sizeof scratch, ".tradeoff-curve.exr");
    job_path(j, pilot_path, sizeof pilot_path, ".tradeoff-pilot.exr");
    if (progress->enabled)
        vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "tradeoff: reference pilot, %d spp\n", PILOT_SPP);
    double pilot_s;
    if ((st = render_reference(j, pilot_path, PILOT_SPP, d->seed + 2, &pilot_s, err)) != VDBS_OK)
        return st;
    vdbs_image pilot = {0};
    if ((st = vdbs_image_read(pilot_path, &pilot, err)) != VDBS_OK)
        return st;
    const double pilot_noise = vdbs_image_noise(&pilot);
    vdbs_image_free(&pilot);
    double spp = PILOT_SPP * (pilot_noise / target) * (pilot_noise / target);
    const double per_spp = pilot_s / PILOT_SPP;
    if (spp * per_spp > limit)
        spp = limit / per_spp;
    spp = fmin(fmax(ceil(spp), 4.0 * PILOT_SPP), 1e8);
    rep->reference_spp = (int)spp;
    if (progress->enabled)
        vdbs_message_emitf(VDBS_MESSAGE_PROGRESS, "tradeoff: reference, %d spp (about %.0f s)\n",
                           rep->reference_spp, spp * per_spp);
    if ((st = render_reference(j, image, rep->reference_spp, d->seed, &rep->reference_seconds,
                               err)) != VDBS_OK ||
        (st = vdbs_image_read(image, &j->reference, err)) != VDBS_OK)
        return st;
    rep->reference_noise = vdbs_image_noise(&j->reference);
    for (int spp_k = 1;
         spp_k * 4 <= rep->reference_spp && rep->curve_count < VDBS_TRADEOFF_MAX_CURVE;
         spp_k *= 4) {
        double s = pilot_s;
        const char *path = spp_k == PILOT_SPP ? pilot_path : scratch;
        if (spp_k != PILOT_SPP)
            st = render_reference(j, scratch, spp_k, d->seed + 2 + (uint64_t)spp_k, &s, err);
        if (st != VDBS_OK || (st = curve_point(j, path, spp_k, s, err)) != VDBS_OK)
            return st;
    }
    remove(pilot_path);
    remove(scratch);
    return reference_write_meta(j, meta, err);
}

/* ---- the ladder ---- */

static vdbs_status run_row(tradeoff_job *j, const char *method, int quality, vdbs_tradeoff_row *row,
                           vdbs_error *err)
{
    const vdbs_tradeoff_desc *d = j->desc;
    int count;
    const vdbs_quality *q = &vdbs_quality_list(&count)[quality];
    snprintf(row->method, sizeof row->method, "%s", method);
    snprintf(row->quality, sizeof row->quality, "%s", q->name);
    vdbs_scene *scene = malloc(sizeof *scene);
    if (!scene)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    *scene = *d->scene;
    if (d->camera) {
        /* The bake frames radiance_view with it and the lit VDB keeps it in its scene, where a
         * camera needs a size: the image's. */
        scene->camera = *d->camera;
        scene->camera.width = j->width;
        scene->camera.height = j->height;
    }
    vdbs_status st = vdbs_scene_set_method(scene, "--methods", method, err);
    if (st == VDBS_OK)
        st = vdbs_scene_set_quality(scene, "--qualities", q->name, err);
    char lit[VDBS_PATH_MAX], image[VDBS_PATH_MAX], name[96];
    job_path(j, lit, sizeof lit, ".tradeoff-lit.vdb");
    snprintf(name, sizeof name, "images/%s-%s.exr", method, q->name);
    job_path(j, image, sizeof image, name);
    vdbs_memory_reset_peak();
    if (st == VDBS_OK) {
        vdbs_bake_options b = {0};
        b.input = j->input;
        b.output = lit;
        b.scene = scene;
        b.backend = d->backend;
        b.store = VDBS_STORE_LIGHTS;
        b.warn = d->warn;
        b.warn_user = d->warn_user;
        b.cancel = d->cancel;
        b.max_memory = d->max_memory;
        vdbs_bake_report bake;
        st = vdbs_bake(&b, &bake, err);
        row->seconds_bake = bake.seconds_total;
    }
    if (st == VDBS_OK) {
        vdbs_render_desc r = {0};
        r.input = lit;
        r.output = image;
        r.mode = VDBS_RENDER_BAKED;
        r.backend = d->backend;
        r.camera = d->camera;
        r.width = j->width;
        r.height = j->height;
        r.warn = d->warn;
        r.warn_user = d->warn_user;
        r.cancel = d->cancel;
        r.max_memory = d->max_memory;
        vdbs_render_report rr;
        st = vdbs_render(&r, &rr, err);
        row->seconds_render = rr.seconds_total;
    }
    free(scene);
    remove(lit);
    const int64_t peak = vdbs_memory_peak();
    row->peak_mib = peak > 0 ? (double)peak / (1024.0 * 1024.0) : -1.0;
    vdbs_image im = {0};
    if (st == VDBS_OK && (st = vdbs_image_read(image, &im, err)) == VDBS_OK) {
        vdbs_tradeoff_metrics m;
        vdbs_tradeoff_measure(im.rgb, j->reference.rgb, j->reference.se, 3ll * j->width * j->height,
                              &m);
        row->relrmse = m.relrmse;
        row->relrmse_se = m.relrmse_se;
        row->mean_ratio = m.mean_ratio;
    }
    vdbs_image_free(&im);
    return st;
}

static double row_seconds(const vdbs_tradeoff_row *row)
{
    return row->seconds_bake + row->seconds_render;
}

static void mark_pareto(vdbs_tradeoff_report *rep)
{
    for (int i = 0; i < rep->row_count; ++i) {
        vdbs_tradeoff_row *a = &rep->rows[i];
        a->pareto = 1;
        for (int k = 0; k < rep->row_count && a->pareto; ++k) {
            const vdbs_tradeoff_row *b = &rep->rows[k];
            if (k != i && row_seconds(b) <= row_seconds(a) && b->relrmse <= a->relrmse &&
                (row_seconds(b) < row_seconds(a) || b->relrmse < a->relrmse || k < i))
                a->pareto = 0;
        }
    }
}

/* ---- the files ---- */

static vdbs_status write_csv(const vdbs_tradeoff_report *rep, vdbs_error *err)
{
    vdbs_text_file out;
    vdbs_status st = vdbs_text_begin(&out, rep->csv, err);
    if (st != VDBS_OK)
        return st;
    FILE *f = out.stream;
    fputs("method,quality,bake_s,render_s,total_s,peak_mib,relrmse,relrmse_se,mean_ratio,"
          "pareto\n",
          f);
    for (int i = 0; i < rep->row_count; ++i) {
        const vdbs_tradeoff_row *r = &rep->rows[i];
        fprintf(f, "%s,%s,%.4f,%.4f,%.4f,%.1f,%.6g,%.3g,%.6g,%d\n", r->method, r->quality,
                r->seconds_bake, r->seconds_render, row_seconds(r), r->peak_mib, r->relrmse,
                r->relrmse_se, r->mean_ratio, r->pareto);
    }
    for (int i = 0; i < rep->curve_count; ++i)
        fprintf(f, "reference,%dspp,0,%.4f,%.4f,,%.6g,,1,0\n", rep->curve[i].spp,
                rep->curve[i].seconds, rep->curve[i].seconds, rep->curve[i].relrmse);
    return vdbs_text_commit(&out, err);
}

/* Seconds the reference needs for an error e, by its 1/sqrt(spp) law through the measured
 * curve (its last point), or -1 without a curve. */
static double reference_seconds_for(const vdbs_tradeoff_report *rep, double e)
{
    for (int i = rep->curve_count - 1; i >= 0; --i) {
        const vdbs_tradeoff_curve_point *p = &rep->curve[i];
        if (p->relrmse > 0.0 && p->seconds > 0.0)
            return p->seconds * (p->relrmse / e) * (p->relrmse / e);
    }
    return -1.0;
}

static vdbs_status write_markdown(const vdbs_tradeoff_report *rep, const char *input,
                                  vdbs_error *err)
{
    vdbs_text_file out;
    vdbs_status st = vdbs_text_begin(&out, rep->markdown, err);
    if (st != VDBS_OK)
        return st;
    FILE *f = out.stream;
    const char *base = strrchr(input, '/');
    fprintf(f, "# Trade-off: %s at %dx%d\n\n", base ? base + 1 : input, rep->width, rep->height);
    fprintf(f,
            "Error: image relative RMSE against a Monte-Carlo reference of %d spp (relative "
            "noise %.4f, %.1f s%s), its noise removed; +- one standard error. Seconds: bake + "
            "baked render.\n\n",
            rep->reference_spp, rep->reference_noise, rep->reference_seconds,
            rep->reference_cached ? ", from the cache" : "");
    fputs("## Cheapest setting per error level\n\n"
          "| error at most | cheapest | seconds | its error | reference alone, s |\n"
          "|---|---|---|---|---|\n",
          f);
    static const double levels[] = {0.3, 0.15, 0.08, 0.04, 0.02};
    for (size_t l = 0; l < sizeof levels / sizeof levels[0]; ++l) {
        const vdbs_tradeoff_row *best = NULL;
        for (int i = 0; i < rep->row_count; ++i)
            if (rep->rows[i].relrmse <= levels[l] &&
                (!best || row_seconds(&rep->rows[i]) < row_seconds(best)))
                best = &rep->rows[i];
        const double ref_s = reference_seconds_for(rep, levels[l]);
        if (best)
            fprintf(f, "| %.2f | %s %s | %.2f | %.4f | %.1f |\n", levels[l], best->method,
                    best->quality, row_seconds(best), best->relrmse, ref_s);
        else
            fprintf(f, "| %.2f | none reaches it | - | - | %.1f |\n", levels[l], ref_s);
    }
    fputs("\n## Every run\n\n"
          "| method | quality | bake s | render s | peak MiB | error | +- | mean ratio | Pareto "
          "|\n|---|---|---|---|---|---|---|---|---|\n",
          f);
    for (int i = 0; i < rep->row_count; ++i) {
        const vdbs_tradeoff_row *r = &rep->rows[i];
        fprintf(f, "| %s | %s | %.2f | %.2f | %.0f | %.4f | %.4f | %.3f | %s |\n", r->method,
                r->quality, r->seconds_bake, r->seconds_render, r->peak_mib, r->relrmse,
                r->relrmse_se, r->mean_ratio, r->pareto ? "yes" : "");
    }
    fputs("\n## The reference alone\n\n| spp | seconds | error |\n|---|---|---|\n", f);
    for (int i = 0; i < rep->curve_count; ++i)
        fprintf(f, "| %d | %.2f | %.4f |\n", rep->curve[i].spp, rep->curve[i].seconds,
                rep->curve[i].relrmse);
    return vdbs_text_commit(&out, err);
}

static vdbs_status write_plot(const vdbs_tradeoff_report *rep, const char *input, vdbs_error *err)
{
    /* x, y and labels for each method, the front and the reference's curve. */
    const int n = rep->row_count;
    double *x = calloc((size_t)(3 * n + 2 * VDBS_TRADEOFF_MAX_CURVE), sizeof *x);
    const char **labels = calloc((size_t)n + 1, sizeof *labels);
    vdbs_plot_series series[VDBS_TRADEOFF_MAX_METHODS + 2];
    memset(series, 0, sizeof series);
    if (!x || !labels) {
        free(x);
        free(labels);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    }
    double *y = x + n, *fx = y + n, *cx = fx + n, *cy = cx + VDBS_TRADEOFF_MAX_CURVE;
    int count = 0;
    for (int i = 0; i < n; ++i) {
        x[i] = row_seconds(&rep->rows[i]);
        /* An error below the reference's noise (0 once the noise is removed) is drawn at
         * its standard error, so that it stays on the log axis. */
        y[i] = fmax(rep->rows[i].relrmse, rep->rows[i].relrmse_se);
        labels[i] = rep->rows[i].quality;
        if (i == 0 || strcmp(rep->rows[i].method, rep->rows[i - 1].method) != 0) {
            series[count].name = rep->rows[i].method;
            series[count].x = x + i;
            series[count].y = y + i;
            series[count].labels = labels + i;
            series[count].style = VDBS_PLOT_LINE_POINTS;
            ++count;
        }
        series[count - 1].count++;
    }
    /* The front in order of time: fx holds indices sorted by seconds. */
    int front = 0;
    double *fy = calloc((size_t)n + 1, sizeof *fy);
    for (int i = 0; fy && i < n; ++i)
        if (rep->rows[i].pareto) {
            int k = front++;
            while (k > 0 && fx[k - 1] > x[i]) {
                fx[k] = fx[k - 1];
                fy[k] = fy[k - 1];
                --k;
            }
            fx[k] = x[i];
            fy[k] = y[i];
        }
    if (front > 0) {
        series[count] = (vdbs_plot_series){
            .name = "Pareto front", .x = fx, .y = fy, .count = front, .style = VDBS_PLOT_FRONT};
        ++count;
    }
    for (int i = 0; i < rep->curve_count; ++i) {
        cx[i] = rep->curve[i].seconds;
        cy[i] = rep->curve[i].relrmse;
    }
    if (rep->curve_count > 0) {
        series[count] = (vdbs_plot_series){.name = "reference (fewer spp)",
                                           .x = cx,
                                           .y = cy,
                                           .count = rep->curve_count,
                                           .style = VDBS_PLOT_DASHED};
        ++count;
    }
    char title[512];
    const char *base = strrchr(input, '/');
    snprintf(title, sizeof title, "%s at %dx%d: error against time", base ? base + 1 : input,
             rep->width, rep->height);
    vdbs_plot_desc p = {0};
    p.title = title;
    p.xlabel = "seconds (bake + render)";
    p.ylabel = "relative RMSE";
    p.log_x = p.log_y = 1;
    p.series = series;
    p.series_count = count;
    vdbs_status st = vdbs_plot_write_png(rep->plot, &p, err);
    free(fy);
    free(x);
    free(labels);
    return st;
}

/* mkdir -p. */
static vdbs_status make_dir(const char *path, vdbs_error *err)
{
    char parent[VDBS_PATH_MAX];
    snprintf(parent, sizeof parent, "%s", path);
    for (char *p = parent + 1; *p; ++p)
        if (*p == '/') {
            *p = '\0';
            mkdir(parent, 0777); /* an error shows at the last level */
            *p = '/';
        }
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: cannot create the folder: %s", path,
                              strerror(errno));
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISDIR(st.st_mode))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: not a folder", path);
    return VDBS_OK;
}

vdbs_status vdbs_tradeoff_run(const vdbs_tradeoff_desc *d, vdbs_tradeoff_report *rep,
                              vdbs_error *err)
{
    memset(rep, 0, sizeof *rep);
    const double started = vdbs_now();
    tradeoff_job j = {0};
    j.desc = d;
    j.report = rep;
    j.input = d->input ? d->input : d->scene->volume_file;
    j.width = d->width > 0 ? d->width : VDBS_TRADEOFF_WIDTH;
    j.height = d->height > 0 ? d->height : VDBS_TRADEOFF_HEIGHT;
    rep->width = j.width;
    rep->height = j.height;
    if (!d->dir || !d->dir[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT, "missing -o DIR");
    /* Methods and qualities first, so that a typo costs no reference. */
    const char *methods[VDBS_TRADEOFF_MAX_METHODS];
    int method_count = 0;
    for (int i = 0; i < (d->method_count > 0 ? d->method_count : VDBS_TRADEOFF_MAX_METHODS); ++i) {
        const vdbs_solver *s =
            d->method_count > 0 ? vdbs_solver_find(d->methods[i]) : vdbs_solver_at(i);
        if (!s && d->method_count > 0) {
            char names[256];
            vdbs_solver_names(names, sizeof names);
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--methods: unknown method '%s' (%s)",
                                  d->methods[i], names);
        }
        if (!s)
            break;
        methods[method_count++] = s->name;
    }
    const unsigned qualities = d->qualities ? d->qualities : 7u;
    int quality_count = 0;
    for (int q = 0; q < VDBS_QUALITY_COUNT; ++q)
        quality_count += (qualities >> q) & 1u;
    if (qualities >> VDBS_QUALITY_COUNT)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "qualities: a level past ultra");
    /* The input and scene before any folder is made: a bad file leaves nothing behind. */
    vdbs_render_desc check = {0};
    check.input = j.input;
    check.scene = d->scene;
    check.mode = VDBS_RENDER_REFERENCE;
    check.camera = d->camera;
    check.width = j.width;
    check.height = j.height;
    vdbs_render_input opened;
    vdbs_status st = vdbs_render_open(&check, &opened, err);
    if (st != VDBS_OK)
        return st;
    vdbs_render_input_free(&opened);
    st = make_dir(d->dir, err);
    char images[VDBS_PATH_MAX];
    job_path(&j, images, sizeof images, "images");
    if (st == VDBS_OK)
        st = make_dir(images, err);
    if (st != VDBS_OK)
        return st;
    job_path(&j, rep->csv, sizeof rep->csv, "tradeoff.csv");
    job_path(&j, rep->markdown, sizeof rep->markdown, "tradeoff.md");
    job_path(&j, rep->plot, sizeof rep->plot, "tradeoff.png");
    vdbs_progress progress = {0};
    progress.enabled = d->progress;
    if ((st = make_reference(&j, &progress, err)) != VDBS_OK) {
        vdbs_image_free(&j.reference);
        return st;
    }
    rep->rows = calloc((size_t)(method_count * quality_count), sizeof *rep->rows);
    if (!rep->rows) {
        vdbs_image_free(&j.reference);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    }
    for (int m = 0; m < method_count && st == VDBS_OK; ++m)
        for (int q = 0; q < VDBS_QUALITY_COUNT && st == VDBS_OK; ++q) {
            if (!((qualities >> q) & 1u))
                continue;
            vdbs_tradeoff_row *row = &rep->rows[rep->row_count];
            st = run_row(&j, methods[m], q, row, err);
            if (st != VDBS_OK)
                break;
            ++rep->row_count;
            if (d->progress)
                vdbs_message_emitf(VDBS_MESSAGE_PROGRESS,
                                   "tradeoff: %d/%d %s %s: %.2f s, error %.4f\n", rep->row_count,
                                   method_count * quality_count, row->method, row->quality,
                                   row_seconds(row), row->relrmse);
        }
    vdbs_image_free(&j.reference);
    if (st != VDBS_OK)
        return st;
    mark_pareto(rep);
    if ((st = write_csv(rep, err)) != VDBS_OK ||
        (st = write_markdown(rep, j.input, err)) != VDBS_OK ||
        (st = write_plot(rep, j.input, err)) != VDBS_OK)
        return st;
    rep->seconds_total = vdbs_now() - started;
    return VDBS_OK;
}

void vdbs_tradeoff_report_free(vdbs_tradeoff_report *rep)
{
    free(rep->rows);
    rep->rows = NULL;
    rep->row_count = 0;
}
