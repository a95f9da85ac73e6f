/* POP's multiple-scattering grids (ms, ms_l1x/y/z) against the Monte-Carlo probe
 * vdbs_reference_probe (reference.h), point by point, on the sphere and cloud samples
 * (albedo 0.99, a sun along (0.3,-1,0.2) of irradiance (3,2.9,2.7) and a constant sky
 * (0.2,0.3,0.5), as bench/bench_pop.py), for g = 0, 0.5, 0.85 and POP at several --pop-res.
 *
 * Points: centres of voxels whose density is > 0, every (n / N)-th of them in index order
 * (k, j, i), N = --points. The probe estimates the average over a ball of radius
 * --radius-voxels voxels around each point, so POP's field is averaged over the same ball:
 * the trilinear interpolant of its output voxels on a lattice a quarter voxel apart inside the
 * ball (corners that are not output voxels are dropped and the weights renormalised, as the
 * lit VDB has no value there). The voxel value at the centre is compared too (column
 * "voxel"): it differs from the ball average by about radius^2 / 10 times the Laplacian.
 *
 * Scalars are the mean of the three channels (the channels share photons, so the se of the
 * mean is the mean of the se's). Per case:
 *   probe median rel se   median over points of se / ms
 *   ms noise floor        sqrt(sum se^2 / sum probe^2): the rel RMSE a perfect POP would get
 *   ms rel RMSE           sqrt(sum (pop - probe)^2 / sum probe^2), pop the ball average
 *   mean pop/probe        mean over points of pop / probe
 *   ms_l1 rel RMSE        the same with vectors: sqrt(sum |pop - probe|^2 / sum |probe|^2)
 *   ms_l1 along sun       sum (pop . s) / sum (probe . s), s the sun's travel direction
 * The probe depends on the scene and g only, so it runs once per (scene, g); its time is
 * listed beside each POP solve's (S1 + POP, C path).
 *
 * With --method fld the same for FLD, --res then giving --fld-res (columns keep POP's names);
 * --method svd the same for SVD (rows per --qualities). --sky boundary sets FLD's and SVD's
 * sky option (solver.fld_sky / svd_sky) to "boundary".
 * --scenes point adds FLD's validation case of Koerner et al.: a point light of intensity 1 at
 * the centre of the cube sample (48^3, half-size 0.6, density scale 30, albedo 0.99: a
 * diffusion length of 4.6 voxels, a mean free path of 0.8), no other light.
 *
 * --scenes smoke_point,cloud_point: POP part 2's point lights, one of intensity 1 inside the
 * smoke sample (64^3, density scale 10, at (0, -0.5, 0)) and one outside the cloud sample (64^3,
 * density scale 20, at (0, 1.6, 0), above it). --qualities low,medium,... gives a row per
 * quality (sky ordinates, radial grids, epsilon_L) instead of per --res.
 *
 * usage: bench_pop_probe [--out bench/pop_probe.md] [--res 2,3,4,8] [--g 0,0.5,0.85]
 *        [--scenes sphere,cloud,point] [--points 300] [--radius-voxels 2] [--photons-sphere N]
 *        [--photons-cloud N] [--quality medium] [--seed 1] [--tally chord|cell]
 *        [--method pop|fld|svd] [--sky collisions|boundary] [--qualities low,medium,...] */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/runner.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/pop.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/skyfloor.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/volume.h"

#define MAX_LIST 16

typedef struct scene_def {
    const char *label; /* the table's */
    const char *name;  /* the sample */
    int res;
    uint32_t seed;
    double density_scale;
    int64_t photons;
    int point_light; /* 1: a point light of intensity 1 at `point`, nothing else; 0: the sun
                        and the sky */
    double point[3];
} scene_def;

typedef struct options {
    const char *out;
    int res[MAX_LIST], res_count;
    double g[MAX_LIST];
    int g_count;
    int points;
    int tally_cell;     /* --tally cell: the paper's one cell side per crossing */
    const char *method; /* --method pop (default), fld (--res is then --fld-res) or svd */
    int sky_boundary;   /* --sky boundary: solver.fld_sky / svd_sky "boundary" */
    double radius_voxels;
    const char *quality;
    uint64_t seed;
    int sphere, cloud, point, smoke_point, cloud_point;
    const char *qualities[MAX_LIST]; /* --qualities: rows per quality instead of per --res */
    int quality_count;
    int64_t photons_sphere, photons_cloud;
} options;

static void die(const char *what, const vdbs_error *err)
{
    fprintf(stderr, "bench_pop_probe: %s: %s\n", what, err ? err->message : "failed");
    exit(1);
}

/* A solver option by its scene key (solver.h). */
static void set_option(vdbs_scene *scene, const char *key, double value)
{
    vdbs_error err;
    if (vdbs_solver_set(scene, key, value, &err) != VDBS_OK)
        die(key, &err);
}

static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) {
        fprintf(stderr, "bench_pop_probe: out of memory\n");
        exit(1);
    }
    return p;
}

static int parse_ints(const char *s, int *out)
{
    int n = 0;
    while (*s && n < MAX_LIST) {
        char *end;
        out[n++] = (int)strtol(s, &end, 10);
        s = *end == ',' ? end + 1 : end;
        if (end == s && *s)
            break;
    }
    return n;
}

static int parse_doubles(const char *s, double *out)
{
    int n = 0;
    while (*s && n < MAX_LIST) {
        char *end;
        out[n++] = strtod(s, &end);
        s = *end == ',' ? end + 1 : end;
        if (end == s && *s)
            break;
    }
    return n;
}

static void usage(void)
{
    fprintf(
        stderr,
        "usage: bench_pop_probe [--out FILE] [--res 2,3,4,8] [--g 0,0.5,0.85] "
        "[--scenes sphere,cloud,point,smoke_point,cloud_point] [--points 300] [--radius-voxels 2] "
        "[--photons-sphere N] [--photons-cloud N] [--quality medium] [--seed 1] "
        "[--tally chord|cell] [--method pop|fld|svd] [--sky collisions|boundary]\n"
        "       [--qualities low,medium,...]\n");
    exit(2);
}

static void parse_args(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->out = "bench/pop_probe.md";
    o->res_count = parse_ints("2,3,4,8", o->res);
    o->g_count = parse_doubles("0,0.5,0.85", o->g);
    o->points = 300;
    o->radius_voxels = 2.0;
    o->quality = "medium";
    o->seed = 1;
    o->method = "pop";
    o->sphere = o->cloud = 1;
    o->point = 0;
    o->photons_sphere = 8000000;
    o->photons_cloud = 16000000;
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (i + 1 >= argc)
            usage();
        const char *v = argv[++i];
        if (strcmp(a, "--out") == 0)
            o->out = v;
        else if (strcmp(a, "--res") == 0)
            o->res_count = parse_ints(v, o->res);
        else if (strcmp(a, "--g") == 0)
            o->g_count = parse_doubles(v, o->g);
        else if (strcmp(a, "--scenes") == 0) {
            char list[256];
            snprintf(list, sizeof list, "%s", v);
            o->sphere = o->cloud = o->point = o->smoke_point = o->cloud_point = 0;
            for (char *t = strtok(list, ","); t; t = strtok(NULL, ",")) {
                int *flag = !strcmp(t, "sphere")        ? &o->sphere
                            : !strcmp(t, "cloud")       ? &o->cloud
                            : !strcmp(t, "point")       ? &o->point
                            : !strcmp(t, "smoke_point") ? &o->smoke_point
                            : !strcmp(t, "cloud_point") ? &o->cloud_point
                                                        : NULL;
                if (!flag)
                    usage();
                *flag = 1;
            }
        } else if (strcmp(a, "--points") == 0)
            o->points = atoi(v);
        else if (strcmp(a, "--radius-voxels") == 0)
            o->radius_voxels = atof(v);
        else if (strcmp(a, "--photons-sphere") == 0)
            o->photons_sphere = strtoll(v, NULL, 10);
        else if (strcmp(a, "--photons-cloud") == 0)
            o->photons_cloud = strtoll(v, NULL, 10);
        else if (strcmp(a, "--quality") == 0)
            o->quality = v;
        else if (strcmp(a, "--qualities") == 0) {
            static char list[256];
            snprintf(list, sizeof list, "%s", v);
            o->quality_count = 0;
            for (char *t = strtok(list, ","); t && o->quality_count < MAX_LIST;
                 t = strtok(NULL, ","))
                o->qualities[o->quality_count++] = t;
        } else if (strcmp(a, "--seed") == 0)
            o->seed = strtoull(v, NULL, 10);
        else if (strcmp(a, "--tally") == 0 && (!strcmp(v, "chord") || !strcmp(v, "cell")))
            o->tally_cell = strcmp(v, "cell") == 0;
        else if (strcmp(a, "--method") == 0 &&
                 (!strcmp(v, "pop") || !strcmp(v, "fld") || !strcmp(v, "svd")))
            o->method = v;
        else if (strcmp(a, "--sky") == 0 && (!strcmp(v, "collisions") || !strcmp(v, "boundary")))
            o->sky_boundary = strcmp(v, "boundary") == 0;
        else
            usage();
    }
    if (o->points < 1 || o->radius_voxels <= 0.0 || o->res_count < 1 || o->g_count < 1)
        usage();
}

/* Output-voxel lookup: index of voxel (i, j, k) in the volume's coords, or -1. */
typedef struct lookup {
    int lo[3], n[3];
    int64_t *index;
} lookup;

static void lookup_build(const vdbs_volume *v, lookup *l)
{
    int hi[3];
    for (int a = 0; a < 3; ++a) {
        l->lo[a] = INT32_MAX;
        hi[a] = INT32_MIN;
    }
    for (size_t i = 0; i < v->coord_count; ++i)
        for (int a = 0; a < 3; ++a) {
            int c = v->coords[3 * i + a];
            l->lo[a] = c < l->lo[a] ? c : l->lo[a];
            hi[a] = c > hi[a] ? c : hi[a];
        }
    for (int a = 0; a < 3; ++a)
        l->n[a] = hi[a] - l->lo[a] + 1;
    size_t cells = (size_t)l->n[0] * l->n[1] * l->n[2];
    l->index = xcalloc(cells, sizeof(int64_t));
    for (size_t i = 0; i < cells; ++i)
        l->index[i] = -1;
    for (size_t i = 0; i < v->coord_count; ++i) {
        const int32_t *c = v->coords + 3 * i;
        size_t at = ((size_t)(c[2] - l->lo[2]) * l->n[1] + (size_t)(c[1] - l->lo[1])) * l->n[0] +
                    (size_t)(c[0] - l->lo[0]);
        l->index[at] = (int64_t)i;
    }
}

static int64_t lookup_get(const lookup *l, int i, int j, int k)
{
    i -= l->lo[0];
    j -= l->lo[1];
    k -= l->lo[2];
    if (i < 0 || j < 0 || k < 0 || i >= l->n[0] || j >= l->n[1] || k >= l->n[2])
        return -1;
    return l->index[((size_t)k * l->n[1] + (size_t)j) * l->n[0] + (size_t)i];
}

/* The trilinear interpolant of `grids` (count grids of 3 floats per output voxel) at
 * index-space point p, renormalised over the corners that are output voxels; out holds
 * 3 count values. Returns 0 when no corner is an output voxel. */
static int interpolate(const lookup *l, const float *const *grids, int count, const double p[3],
                       double *out)
{
    int base[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        base[a] = (int)floor(p[a]);
        f[a] = p[a] - base[a];
    }
    double wsum = 0.0;
    for (int q = 0; q < 3 * count; ++q)
        out[q] = 0.0;
    for (int c = 0; c < 8; ++c) {
        int d[3] = {c & 1, (c >> 1) & 1, (c >> 2) & 1};
        double w = 1.0;
        for (int a = 0; a < 3; ++a)
            w *= d[a] ? f[a] : 1.0 - f[a];
        if (w <= 0.0)
            continue;
        int64_t v = lookup_get(l, base[0] + d[0], base[1] + d[1], base[2] + d[2]);
        if (v < 0)
            continue;
        wsum += w;
        for (int gi = 0; gi < count; ++gi)
            for (int ch = 0; ch < 3; ++ch)
                out[3 * gi + ch] += w * grids[gi][3 * v + ch];
    }
    if (wsum <= 0.0)
        return 0;
    for (int q = 0; q < 3 * count; ++q)
        out[q] /= wsum;
    return 1;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    if (n == 0)
        return NAN;
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static double mean3(const double *v)
{
    return (v[0] + v[1] + v[2]) / 3.0;
}

/* One row of the table. */
typedef struct row {
    const char *scene;
    double g;
    char setting[16]; /* --res value, or the quality name with --qualities */
    int points;
    double probe_rel_se, ms_floor, ms_rmse, ms_rmse_voxel, ratio;
    double l1_rmse, l1_floor, l1_sun_ratio;
    double probe_seconds, pop_seconds;
    double tercile_ratio[3]; /* mean pop/probe over the points ranked by S1: bright to dark */
    double tercile_s1[3];    /* mean S1 / probe ms there */
} row;

static void print_header(FILE *f)
{
    fprintf(f, "| scene | g | pop-res | points | probe median rel se | ms noise floor | "
               "ms rel RMSE | ms rel RMSE (voxel) | mean pop/probe | ms_l1 rel RMSE | "
               "ms_l1 noise floor | ms_l1 along sun pop/probe | probe s | POP solve s |\n");
    fprintf(f, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
}

static void print_row(FILE *f, const row *r)
{
    fprintf(f, "| %s | %g | %s | %d | %.4f | %.4f | %.3f | %.3f | %.3f | ", r->scene, r->g,
            r->setting, r->points, r->probe_rel_se, r->ms_floor, r->ms_rmse, r->ms_rmse_voxel,
            r->ratio);
    if (r->g > 0.0)
        fprintf(f, "%.3f | %.3f | %.3f | ", r->l1_rmse, r->l1_floor, r->l1_sun_ratio);
    else
        fprintf(f, "- | - | - | ");
    fprintf(f, "%.1f | %.2f |\n", r->probe_seconds, r->pop_seconds);
}

static void print_tercile_header(FILE *f)
{
    fprintf(f, "| scene | g | pop-res | pop/probe, brightest S1 third | middle third | darkest "
               "third | S1 / probe ms: brightest | middle | darkest |\n");
    fprintf(f, "|---|---|---|---|---|---|---|---|---|\n");
}

static void print_tercile_row(FILE *f, const row *r)
{
    fprintf(f, "| %s | %g | %s | %.3f | %.3f | %.3f | %.2f | %.2f | %.2f |\n", r->scene, r->g,
            r->setting, r->tercile_ratio[0], r->tercile_ratio[1], r->tercile_ratio[2],
            r->tercile_s1[0], r->tercile_s1[1], r->tercile_s1[2]);
}

/* Sorts point indices by key, descending. */
static const double *sort_key;
static int cmp_index_desc(const void *a, const void *b)
{
    double x = sort_key[*(const int *)a], y = sort_key[*(const int *)b];
    return (x < y) - (x > y);
}

static void run_scene(const scene_def *def, const options *o, vdbs_runner *runner, row *rows,
                      int *row_count)
{
    vdbs_error err;
    size_t nvox = (size_t)def->res * def->res * def->res;
    float *values = xcalloc(nvox, sizeof(float));
    if (vdbs_sample_fill(def->name, def->res, def->seed, values, &err) != VDBS_OK)
        die(def->name, &err);
    vdbio_density *density = NULL;
    vdbs_volume volume;
    if (vdbs_sample_create(def->name, def->res, def->seed, &density, &err) != VDBS_OK ||
        vdbs_volume_from_density(density, &volume, &err) != VDBS_OK)
        die(def->name, &err);
    lookup lk;
    lookup_build(&volume, &lk);

    /* The points: every (n / N)-th voxel with density > 0, in index order. */
    size_t candidates = 0;
    for (size_t i = 0; i < nvox; ++i)
        candidates += values[i] > 0.0f;
    int npts = o->points < (int)candidates ? o->points : (int)candidates;
    int *vox = xcalloc(3 * (size_t)npts, sizeof(int));
    double *pts = xcalloc(3 * (size_t)npts, sizeof(double));
    {
        size_t seen = 0;
        int next = 0;
        for (size_t i = 0; i < nvox && next < npts; ++i) {
            if (!(values[i] > 0.0f))
                continue;
            size_t want = (size_t)(((double)next + 0.5) * (double)candidates / npts);
            if (seen == want) {
                vox[3 * next + 0] = (int)(i % (size_t)def->res);
                vox[3 * next + 1] = (int)((i / (size_t)def->res) % (size_t)def->res);
                vox[3 * next + 2] = (int)(i / ((size_t)def->res * def->res));
                double ip[3] = {vox[3 * next], vox[3 * next + 1], vox[3 * next + 2]};
                vdbs_volume_world_point(&volume, ip, pts + 3 * next);
                if (lookup_get(&lk, vox[3 * next], vox[3 * next + 1], vox[3 * next + 2]) < 0) {
                    fprintf(stderr, "bench_pop_probe: voxel with density is not an output voxel\n");
                    exit(1);
                }
                ++next;
            }
            ++seen;
        }
    }
    free(values);

    /* The ball-averaging lattice, in index space (cubic voxels). */
    const double step = 0.25, rv = o->radius_voxels;
    int m = (int)floor(rv / step);
    int nq = 0;
    double *lat = xcalloc(3 * (size_t)(2 * m + 1) * (2 * m + 1) * (2 * m + 1), sizeof(double));
    for (int a = -m; a <= m; ++a)
        for (int b = -m; b <= m; ++b)
            for (int c = -m; c <= m; ++c)
                if ((a * a + b * b + c * c) * step * step <= rv * rv + 1e-12) {
                    lat[3 * nq + 0] = a * step;
                    lat[3 * nq + 1] = b * step;
                    lat[3 * nq + 2] = c * step;
                    ++nq;
                }
    const double radius = rv * volume.mean_voxel_size;
    fprintf(stderr,
            "%s: %zu voxels with density, %d points, %zu output voxels, ball radius %g "
            "(%d lattice points)\n",
            def->name, candidates, npts, volume.coord_count, radius, nq);

    const vdbs_quality *quality = vdbs_quality_find(o->quality);
    if (!quality) {
        fprintf(stderr, "bench_pop_probe: unknown quality %s\n", o->quality);
        exit(2);
    }
    double *pms = xcalloc(3 * (size_t)npts, sizeof(double));
    double *pl1 = xcalloc(9 * (size_t)npts, sizeof(double));
    double *pms_se = xcalloc(3 * (size_t)npts, sizeof(double));
    double *pl1_se = xcalloc(9 * (size_t)npts, sizeof(double));
    double *work = xcalloc((size_t)npts, sizeof(double));
    double *ratio = xcalloc((size_t)npts, sizeof(double)),
           *s1 = xcalloc((size_t)npts, sizeof(double));
    int *order = xcalloc((size_t)npts, sizeof(int));
    size_t n = volume.coord_count;
    float *radiance = xcalloc(3 * n, sizeof(float)), *ms = xcalloc(3 * n, sizeof(float));
    float *l1[3];
    for (int a = 0; a < 3; ++a)
        l1[a] = xcalloc(3 * n, sizeof(float));

    for (int gi = 0; gi < o->g_count; ++gi) {
        vdbs_scene scene;
        vdbs_scene_init(&scene);
        scene.density_scale = def->density_scale;
        for (int c = 0; c < 3; ++c)
            scene.albedo[c] = 0.99;
        scene.g = o->g[gi];
        if (def->point_light) {
            vdbs_light *point = &scene.lights[scene.light_count++];
            memset(point, 0, sizeof *point);
            point->type = VDBS_LIGHT_POINT;
            for (int c = 0; c < 3; ++c) {
                point->color[c] = 1.0;
                point->position[c] = def->point[c];
            }
        } else {
            vdbs_light *sun = &scene.lights[scene.light_count++];
            memset(sun, 0, sizeof *sun);
            sun->type = VDBS_LIGHT_SUN;
            sun->direction[0] = 0.3;
            sun->direction[1] = -1.0;
            sun->direction[2] = 0.2;
            sun->color[0] = 3.0;
            sun->color[1] = 2.9;
            sun->color[2] = 2.7;
            vdbs_light *sky = &scene.lights[scene.light_count++];
            memset(sky, 0, sizeof *sky);
            sky->type = VDBS_LIGHT_ENV;
            sky->color[0] = 0.2;
            sky->color[1] = 0.3;
            sky->color[2] = 0.5;
            sky->env_scale = 1.0;
        }
        snprintf(scene.method, sizeof scene.method, "%s", o->method);
        snprintf(scene.quality, sizeof scene.quality, "%s", o->quality);
        if (vdbs_scene_validate(&scene, &err) != VDBS_OK)
            die("scene", &err);
        /* "along sun": the sun's direction after validate (unit); for the point light the
         * +x axis, a direction without meaning for a radial field. */
        const double *s =
            def->point_light ? (const double[3]){1.0, 0.0, 0.0} : scene.lights[0].direction;

        /* The probe, once per (scene, g). */
        vdbs_reference_probe_options po = {0};
        po.photons = def->photons;
        po.radius = radius;
        po.seed = o->seed;
        double t0 = vdbs_now();
        if (vdbs_reference_probe(&volume, &scene, &po, pts, (size_t)npts, pms, pl1, pms_se, pl1_se,
                                 &err) != VDBS_OK)
            die("probe", &err);
        double probe_seconds = vdbs_now() - t0;

        /* Probe statistics that do not depend on POP. */
        double sum_p2 = 0.0, sum_se2 = 0.0, sum_l2 = 0.0, sum_lse2 = 0.0;
        for (int i = 0; i < npts; ++i) {
            double p = mean3(pms + 3 * i), se = mean3(pms_se + 3 * i);
            work[i] = p > 0.0 ? se / p : INFINITY;
            sum_p2 += p * p;
            sum_se2 += se * se;
            for (int a = 0; a < 3; ++a) {
                double la = mean3(pl1 + 9 * i + 3 * a), lse = mean3(pl1_se + 9 * i + 3 * a);
                sum_l2 += la * la;
                sum_lse2 += lse * lse;
            }
        }
        double probe_rel_se = median(work, npts);
        fprintf(stderr, "%s g %g: probe %lld photons, %.1f s, median rel se %.4f\n", def->name,
                scene.g, (long long)def->photons, probe_seconds, probe_rel_se);

        const int settings = o->quality_count > 0 ? o->quality_count : o->res_count;
        for (int ri = 0; ri < settings; ++ri) {
            if (o->quality_count > 0) {
                snprintf(scene.quality, sizeof scene.quality, "%s", o->qualities[ri]);
                quality = vdbs_quality_find(scene.quality);
                if (!quality)
                    die("--qualities: unknown quality", NULL);
            } else {
                set_option(&scene, "pop_res", o->res[ri]);
                set_option(&scene, "fld_res", o->res[ri]);
            }
            set_option(&scene, "pop_tally", o->tally_cell);
            if (o->sky_boundary) {
                set_option(&scene, "fld_sky", VDBS_SKY_BOUNDARY);
                set_option(&scene, "svd_sky", VDBS_SKY_BOUNDARY);
            }
            const vdbs_solver *solver = vdbs_solver_find(o->method);
            vdbs_lights_desc ld = {0};
            ld.sky_ordinates =
                scene.sky_directions > 0 ? scene.sky_directions : quality->sky_directions;
            vdbs_light_table lights;
            if (vdbs_lights_build(&volume, &scene, &ld, &lights, &err) != VDBS_OK)
                die("lights", &err);
            memset(radiance, 0, 3 * n * sizeof(float));
            memset(ms, 0, 3 * n * sizeof(float));
            for (int a = 0; a < 3; ++a)
                memset(l1[a], 0, 3 * n * sizeof(float));
            vdbs_light_grid_desc grids = {0, 0, 0.0};
            vdbs_s1_stats s1_stats;
            memset(&s1_stats, 0, sizeof s1_stats);
            union {
                vdbs_pop_stats pop;
                unsigned char bytes[VDBS_SOLVER_STATS_MAX];
            } stats;
            memset(&stats, 0, sizeof stats);
            vdbs_solve solve;
            memset(&solve, 0, sizeof solve);
            solve.runner = runner;
            solve.volume = &volume;
            solve.scene = &scene;
            solve.lights = &lights;
            solve.quality = quality;
            solve.s1_grids = &grids;
            solve.s1_stats = &s1_stats;
            solve.radiance = radiance;
            solve.ms = ms;
            for (int a = 0; a < 3; ++a)
                solve.ms_l1[a] = l1[a];
            t0 = vdbs_now();
            if (solver->run(&solve, stats.bytes, &err) != VDBS_OK)
                die(o->method, &err);
            double pop_seconds = vdbs_now() - t0;
            vdbs_lights_free(&lights);

            /* POP at the points: ball averages and the voxel values. */
            const float *const all[4] = {ms, l1[0], l1[1], l1[2]};
            double sum_d2 = 0.0, sum_dv2 = 0.0, sum_ratio = 0.0, sum_dl2 = 0.0;
            double sun_pop = 0.0, sun_probe = 0.0;
            int ratios = 0;
            for (int i = 0; i < npts; ++i) {
                double acc[12] = {0}, val[12];
                int used = 0;
                for (int q = 0; q < nq; ++q) {
                    double p[3];
                    for (int a = 0; a < 3; ++a)
                        p[a] = vox[3 * i + a] + lat[3 * q + a];
                    if (!interpolate(&lk, all, 4, p, val))
                        continue;
                    for (int k = 0; k < 12; ++k)
                        acc[k] += val[k];
                    ++used;
                }
                for (int k = 0; k < 12; ++k)
                    acc[k] /= used > 0 ? used : 1;
                int64_t v = lookup_get(&lk, vox[3 * i], vox[3 * i + 1], vox[3 * i + 2]);
                double voxel = (ms[3 * v] + ms[3 * v + 1] + ms[3 * v + 2]) / 3.0;
                double pop = mean3(acc), probe = mean3(pms + 3 * i);
                s1[i] = (radiance[3 * v] + radiance[3 * v + 1] + radiance[3 * v + 2]) / 3.0 - voxel;
                ratio[i] = probe > 0.0 ? pop / probe : NAN;
                work[i] = probe > 0.0 ? s1[i] / probe : NAN;
                order[i] = i;
                sum_d2 += (pop - probe) * (pop - probe);
                sum_dv2 += (voxel - probe) * (voxel - probe);
                if (probe > 0.0) {
                    sum_ratio += pop / probe;
                    ++ratios;
                }
                for (int a = 0; a < 3; ++a) {
                    double lp = mean3(acc + 3 + 3 * a), lr = mean3(pl1 + 9 * i + 3 * a);
                    sum_dl2 += (lp - lr) * (lp - lr);
                    sun_pop += lp * s[a];
                    sun_probe += lr * s[a];
                }
            }
            row *r = &rows[(*row_count)++];
            memset(r, 0, sizeof *r);
            r->scene = def->label;
            r->g = scene.g;
            if (o->quality_count > 0)
                snprintf(r->setting, sizeof r->setting, "%s", o->qualities[ri]);
            else
                snprintf(r->setting, sizeof r->setting, "%d", o->res[ri]);
            r->points = npts;
            r->probe_rel_se = probe_rel_se;
            r->ms_floor = sqrt(sum_se2 / sum_p2);
            r->ms_rmse = sqrt(sum_d2 / sum_p2);
            r->ms_rmse_voxel = sqrt(sum_dv2 / sum_p2);
            r->ratio = ratios ? sum_ratio / ratios : NAN;
            r->l1_rmse = sum_l2 > 0.0 ? sqrt(sum_dl2 / sum_l2) : NAN;
            r->l1_floor = sum_l2 > 0.0 ? sqrt(sum_lse2 / sum_l2) : NAN;
            r->l1_sun_ratio = sun_probe != 0.0 ? sun_pop / sun_probe : NAN;
            r->probe_seconds = probe_seconds;
            r->pop_seconds = pop_seconds;
            sort_key = s1;
            qsort(order, (size_t)npts, sizeof(int), cmp_index_desc);
            for (int t = 0; t < 3; ++t) {
                int from = t * npts / 3, to = (t + 1) * npts / 3, k = 0;
                double sr = 0.0, ss = 0.0;
                for (int q = from; q < to; ++q)
                    if (isfinite(ratio[order[q]])) {
                        sr += ratio[order[q]];
                        ss += work[order[q]];
                        ++k;
                    }
                r->tercile_ratio[t] = k ? sr / k : NAN;
                r->tercile_s1[t] = k ? ss / k : NAN;
            }
            print_row(stdout, r);
            fflush(stdout);
        }
    }
    for (int a = 0; a < 3; ++a)
        free(l1[a]);
    free(ms);
    free(radiance);
    free(work);
    free(ratio);
    free(s1);
    free(order);
    free(pms);
    free(pl1);
    free(pms_se);
    free(pl1_se);
    free(lat);
    free(pts);
    free(vox);
    free(lk.index);
    vdbs_volume_free(&volume);
}

int main(int argc, char **argv)
{
    options o;
    parse_args(argc, argv, &o);
    const scene_def defs[5] = {
        {"sphere", "sphere", 32, 1, 3.0, o.photons_sphere, 0, {0, 0, 0}},
        {"cloud", "cloud", 64, 1, 20.0, o.photons_cloud, 0, {0, 0, 0}},
        {"point in the cube", "cube", 48, 1, 30.0, o.photons_sphere, 1, {0, 0, 0}},
        {"point in the smoke", "smoke", 64, 1, 10.0, o.photons_cloud, 1, {0.0, -0.5, 0.0}},
        {"point outside the cloud", "cloud", 64, 1, 20.0, o.photons_cloud, 1, {0.0, 1.6, 0.0}},
    };
    vdbs_runner_desc rd = {.backend = VDBS_BACKEND_CPU};
    vdbs_runner *runner = NULL;
    vdbs_error err;
    if (vdbs_runner_create(&rd, &runner, &err) != VDBS_OK)
        die("runner", &err);
    int max_rows = 5 * o.g_count * (o.quality_count > o.res_count ? o.quality_count : o.res_count);
    row *rows = xcalloc((size_t)max_rows, sizeof(row));
    int count = 0;
    double t0 = vdbs_now();
    print_header(stdout);
    const int wanted[5] = {o.sphere, o.cloud, o.point, o.smoke_point, o.cloud_point};
    for (int d = 0; d < 5; ++d)
        if (wanted[d])
            run_scene(&defs[d], &o, runner, rows, &count);
    double total = vdbs_now() - t0;

    FILE *f = fopen(o.out, "w");
    if (!f) {
        fprintf(stderr, "bench_pop_probe: cannot write %s\n", o.out);
        return 1;
    }
    fprintf(f, "`");
    for (int i = 0; i < argc; ++i)
        fprintf(f, "%s%s", i ? " " : "", argv[i]);
    fprintf(f, "` (%s, %.0f s in all)\n\n", vdbs_runner_device(runner), total);
    fprintf(f,
            "--method %s: ms / ms_l1 (C path, quality %s; pop-res is --fld-res for fld) against "
            "vdbs_reference_probe at voxel centres "
            "with density > 0, both averaged over a ball of %g voxels (POP: its trilinear "
            "interpolant on a quarter-voxel lattice; \"voxel\": POP's voxel value instead). "
            "Channel means; rel RMSE = sqrt(sum (pop - probe)^2 / sum probe^2); noise floor = "
            "sqrt(sum se^2 / sum probe^2); ms_l1 as 3-vectors; \"along sun\" = sum (pop . s) / "
            "sum (probe . s). Probe seconds are per (scene, g), POP solve seconds (S1 + POP) per "
            "row. Definitions: bench/bench_pop_probe.c.\n\n",
            o.method, o.quality, o.radius_voxels);
    print_header(f);
    for (int i = 0; i < count; ++i)
        print_row(f, &rows[i]);
    fprintf(f, "\nWhere the bias sits: the points ranked by POP's S1 at the voxel (the sun- and "
               "sky-lit part, from the same solve) and split in thirds; the mean of pop/probe in "
               "each, and the mean S1 / probe ms there.\n\n");
    print_tercile_header(f);
    for (int i = 0; i < count; ++i)
        print_tercile_row(f, &rows[i]);
    fclose(f);
    printf("\n");
    print_tercile_header(stdout);
    for (int i = 0; i < count; ++i)
        print_tercile_row(stdout, &rows[i]);
    printf("\nwritten %s (%.0f s in all)\n", o.out, total);
    free(rows);
    vdbs_runner_destroy(runner);
    return 0;
}
