/* The extremes matrix over every solver of the table (solver.h, iterated by vdbs_solver_at so
 * that a solver added later is covered unchanged): albedo, g, optical thickness per voxel,
 * light scale, light kind and volume, driven through vdbs_bake_volume at quality low.
 *
 * - The full albedo x g x thickness grid (200 cases per solver) on an 8^3 cube under a sun;
 *   the other axes by a pairwise covering array built here (greedy, deterministic) whose
 *   coverage is asserted.
 * - Every case: every output value finite and >= 0 (ms_l1 finite with |ms_l1| <= 3 |g| ms,
 *   docs/design.md "output grids": |integral L w dw| <= integral L dw); absorbed power
 *   4 pi sum sigma_a radiance V at most the power that entered (a bound from the lights and
 *   the support box); the solver's own balance within its stated tolerance; iterations within
 *   their caps, converged => residual <= requested, not converged short of the cap only where
 *   the solver's own prediction passed it; a light scale 2^+-20 gives the scale-1 result times
 *   the factor.
 * - The reference path tracer renders finite, non-negative images at the corners.
 * - The white furnace (albedo 1, sky of radiance 1): every solver that writes ms, at high, on
 *   the cube and the cloud for three g, against the target (POP measured only).
 *
 * Without an argument the slice runs (the grid's corners and former findings, and the covering
 * array's rows on the small volumes, for the default suite); `test_extremes full` (ctest
 * test_extremes_full, label long) runs everything. VDBSCATTER_EXTREMES_TABLE=PATH writes the
 * per-solver table (bench/extremes.md). */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "exrwrite.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/camera.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/solver.h"

#define PI 3.14159265358979323846

static const double ALBEDOS[] = {0.0, 0.5, 0.99, 0.999, 1.0};
static const double GS[] = {-0.999, -0.9, -0.5, 0.0, 0.5, 0.9, 0.99, 0.999};
static const double TAUS[] = {1e-6, 1e-2, 1.0, 1e2, 1e4};
static const double SCALES[] = {0x1p-20, 1.0, 0x1p20};
enum { LIGHT_SUN, LIGHT_POINT_IN, LIGHT_POINT_OUT, LIGHT_SKY, LIGHT_ENV, LIGHT_KINDS };
static const char *const LIGHT_NAMES[] = {"sun", "point inside", "point outside", "sky", "env map"};
enum { VOL_ONE, VOL_CUBE, VOL_BLOBS, VOL_CLOUD, VOL_KINDS };
static const char *const VOL_NAMES[] = {"one voxel", "8^3 cube", "two blobs", "cloud"};

#define N_ALBEDO ((int)(sizeof ALBEDOS / sizeof ALBEDOS[0]))
#define N_G ((int)(sizeof GS / sizeof GS[0]))
#define N_TAU ((int)(sizeof TAUS / sizeof TAUS[0]))
#define N_SCALE ((int)(sizeof SCALES / sizeof SCALES[0]))

/* Axes of the covering array, in this order. */
#define AXES 6
static const int AXIS_SIZE[AXES] = {VOL_KINDS, LIGHT_KINDS, N_ALBEDO, N_G, N_TAU, N_SCALE};
enum { AX_VOL, AX_LIGHT, AX_ALBEDO, AX_G, AX_TAU, AX_SCALE };
#define MAX_ROWS 128
#define MAX_SOLVERS 16

static const double VOXEL = 0.1; /* world side of a voxel */

typedef struct row_stats {
    int cases;
    double energy;     /* worst absorbed / entered */
    double balance;    /* worst of the solver's own balance (relative) */
    double iter_ratio; /* worst iterations / cap */
    int iterations, cap;
    double linearity; /* worst relative error of the scaled result */
    double worst;     /* the largest output value met */
    int failures;
} row_stats;

static row_stats STATS[MAX_SOLVERS];
static int FAILURES;
static char FIRST_FAILURE[512];

static void finding(const char *fmt, ...)
{
    char text[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    print_message("FINDING: %s\n", text);
    if (FAILURES++ == 0)
        snprintf(FIRST_FAILURE, sizeof FIRST_FAILURE, "%s", text);
}

/* A dense block of density 1 (value(i,j,k) != 0 where `keep` says), voxel side VOXEL. */
static void make_dense(int nx, int ny, int nz, int (*keep)(int, int, int), vdbs_volume *volume)
{
    float *values = malloc(sizeof(float) * (size_t)nx * ny * nz);
    assert_non_null(values);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i)
                values[((size_t)k * ny + j) * nx + i] = keep == NULL || keep(i, j, k) ? 1.0f : 0.0f;
    int dims[3] = {nx, ny, nz}, origin[3] = {0, 0, 0};
    vdbio_transform xf;
    memset(&xf, 0, sizeof xf);
    xf.m[0][0] = xf.m[1][1] = xf.m[2][2] = VOXEL;
    test_dense_volume(values, dims, origin, &xf, volume);
}

static int two_blobs(int i, int j, int k)
{
    (void)j;
    (void)k;
    return i < 3 || i >= 27; /* two 3^3 blobs 24 voxels apart */
}

static void make_volume(int kind, vdbs_volume *volume)
{
    switch (kind) {
    case VOL_ONE:
        make_dense(1, 1, 1, NULL, volume);
        break;
    case VOL_CUBE:
        make_dense(8, 8, 8, NULL, volume);
        break;
    case VOL_BLOBS:
        make_dense(30, 3, 3, two_blobs, volume);
        break;
    default: {
        /* its own voxel side: make_scene sets the density scale per voxel side */
        test_sample_volume("cloud", 16, 1, volume);
        break;
    }
    }
}

/* The env map with one hot texel (8 x 4 lat-long, base 0.25, one texel 1024), written once. */
#define ENV_W 8
#define ENV_H 4
static const float ENV_BASE = 0.25f, ENV_HOT = 1024.0f;
static const int ENV_HOT_X = 3, ENV_HOT_Y = 1;
static const char *env_path(void)
{
    static char path[VDBS_PATH_MAX];
    if (path[0])
        return path;
    snprintf(path, sizeof path, "%s", test_tmp_path("extremes_env.exr"));
    float plane[ENV_W * ENV_H];
    for (int i = 0; i < ENV_W * ENV_H; ++i)
        plane[i] = ENV_BASE;
    plane[ENV_HOT_Y * ENV_W + ENV_HOT_X] = ENV_HOT;
    const float *planes[3] = {plane, plane, plane};
    test_exr_spec spec = {"R,G,B", "float", "none", NULL, {0, 0, ENV_W - 1, ENV_H - 1}, {0}};
    const char *why = test_exr_write(path, &spec, planes);
    if (why)
        fail_msg("env map: %s", why);
    return path;
}

/* integral of the env map's radiance over the sphere (per channel, scale 1): each lat-long row
 * y spans polar angles y pi / H .. (y + 1) pi / H (either way up: rows mirror to the same). */
static double env_integral(void)
{
    double total = 0.0;
    for (int y = 0; y < ENV_H; ++y) {
        const double omega = 2.0 * PI / ENV_W * (cos(y * PI / ENV_H) - cos((y + 1) * PI / ENV_H));
        for (int x = 0; x < ENV_W; ++x)
            total += omega * (x == ENV_HOT_X && y == ENV_HOT_Y ? ENV_HOT : ENV_BASE);
    }
    return total;
}

typedef struct box {
    double lo[3], hi[3];
} box;

/* The scene of a case: one light of `kind` and colour scale `s` (colours 1, 2, 0.5 times s). */
static void make_scene(vdbs_scene *scene, const vdbs_solver *solver, int light, double albedo,
                       double g, double tau, double s, const box *b, double voxel)
{
    vdbs_scene_init(scene);
    snprintf(scene->method, sizeof scene->method, "%s", solver->name);
    snprintf(scene->quality, sizeof scene->quality, "low");
    scene->density_scale = tau / voxel; /* tau per voxel of density 1 */
    scene->albedo[0] = scene->albedo[1] = scene->albedo[2] = albedo;
    scene->g = g;
    vdbs_light *l = &scene->lights[0];
    memset(l, 0, sizeof *l);
    scene->light_count = 1;
    const double c[3] = {s, 2.0 * s, 0.5 * s};
    double mid[3], ext = 0.0;
    for (int a = 0; a < 3; ++a) {
        mid[a] = 0.5 * (b->lo[a] + b->hi[a]);
        ext = fmax(ext, b->hi[a] - b->lo[a]);
    }
    switch (light) {
    case LIGHT_SUN:
        l->type = VDBS_LIGHT_SUN;
        l->direction[0] = 0.3, l->direction[1] = -1.0, l->direction[2] = 0.2;
        break;
    case LIGHT_POINT_IN:
    case LIGHT_POINT_OUT:
        l->type = VDBS_LIGHT_POINT;
        for (int a = 0; a < 3; ++a)
            l->position[a] = mid[a];
        if (light == LIGHT_POINT_OUT)
            l->position[0] += 0.2, l->position[1] += 2.0 * ext + 0.3, l->position[2] -= 0.1;
        break;
    case LIGHT_SKY:
        l->type = VDBS_LIGHT_ENV;
        break;
    default: {
        l->type = VDBS_LIGHT_ENV;
        vdbs_error err;
        assert_int_equal(vdbs_light_set_env_file(scene, l, env_path(), &err), VDBS_OK);
        break;
    }
    }
    if (light == LIGHT_ENV) {
        l->color[0] = l->color[1] = l->color[2] = 1.0;
        l->env_scale = s; /* the map is grey: channels differ by nothing but the scale */
    } else {
        memcpy(l->color, c, sizeof c);
        l->env_scale = light == LIGHT_SKY ? 1.0 : 0.0;
    }
    vdbs_error err;
    if (vdbs_scene_validate(scene, &err) != VDBS_OK)
        fail_msg("scene: %s", err.message);
}

/* Upper bound of the power (per channel) that enters the support box from the case's light. */
static void entering_power(const vdbs_scene *scene, int light, const box *b, double out[3])
{
    const vdbs_light *l = &scene->lights[0];
    double side[3], area[3], mid[3], radius = 0.0;
    for (int a = 0; a < 3; ++a) {
        side[a] = b->hi[a] - b->lo[a];
        mid[a] = 0.5 * (b->lo[a] + b->hi[a]);
        radius += 0.25 * side[a] * side[a];
    }
    radius = sqrt(radius);
    area[0] = side[1] * side[2], area[1] = side[0] * side[2], area[2] = side[0] * side[1];
    double factor = 0.0;
    switch (light) {
    case LIGHT_SUN: {
        double d[3], n = 0.0;
        for (int a = 0; a < 3; ++a)
            n += l->direction[a] * l->direction[a];
        for (int a = 0; a < 3; ++a)
            d[a] = l->direction[a] / sqrt(n);
        /* irradiance times the box's projected area */
        factor = fabs(d[0]) * area[0] + fabs(d[1]) * area[1] + fabs(d[2]) * area[2];
        break;
    }
    case LIGHT_POINT_IN:
        factor = 4.0 * PI;
        break;
    case LIGHT_POINT_OUT: {
        /* intensity times the solid angle of the box's bounding sphere (>= the box's) */
        double dist = 0.0;
        for (int a = 0; a < 3; ++a)
            dist += (l->position[a] - mid[a]) * (l->position[a] - mid[a]);
        dist = sqrt(dist);
        factor = dist > radius ? 2.0 * PI * (1.0 - sqrt(1.0 - radius * radius / (dist * dist)))
                               : 4.0 * PI;
        break;
    }
    case LIGHT_SKY:
        factor = PI * 2.0 * (area[0] + area[1] + area[2]);
        break;
    default: {
        /* the largest projected area of a box is at most the sum of three face areas;
         * the power is at most that times the integral of the radiance over the sphere */
        const double ones[3] = {1.0, 1.0, 1.0};
        for (int c = 0; c < 3; ++c)
            out[c] = (area[0] + area[1] + area[2]) * env_integral() * l->env_scale * ones[c];
        return;
    }
    }
    for (int c = 0; c < 3; ++c)
        out[c] = factor * l->color[c];
}

/* A number of the solver's report block by key (not a stage time); 0 when it has none. */
static int report_value(const vdbs_solver *solver, const void *stats, const char *key, double *v)
{
    for (int i = 0; i < solver->report_count; ++i) {
        const vdbs_report_field *f = &solver->report[i];
        if (strcmp(f->key, key) != 0 || f->kind == VDBS_REPORT_SECONDS)
            continue;
        const unsigned char *p = (const unsigned char *)stats + f->offset;
        switch (f->kind) {
        case VDBS_REPORT_INT:
        case VDBS_REPORT_BOOL:
        case VDBS_REPORT_ON_OFF: {
            int x;
            memcpy(&x, p, sizeof x);
            *v = x;
            return 1;
        }
        case VDBS_REPORT_INT64: {
            long long x;
            memcpy(&x, p, sizeof x);
            *v = (double)x;
            return 1;
        }
        default: {
            double x;
            memcpy(&x, p, sizeof x);
            *v = x;
            return 1;
        }
        }
    }
    return 0;
}

/* An option's value at low quality by key suffix ("_iterations"); 0 when it has none. */
static double option_value(const vdbs_solver *solver, const vdbs_scene *scene, const char *suffix)
{
    const vdbs_quality *q = vdbs_quality_find("low");
    for (int i = 0; i < solver->option_count; ++i) {
        const char *key = solver->options[i].key;
        size_t n = strlen(key), m = strlen(suffix);
        if (n > m && strcmp(key + n - m, suffix) == 0)
            return vdbs_solver_option_value(scene, &solver->options[i], q);
    }
    return 0.0;
}

typedef struct outputs {
    size_t n;
    float *radiance, *ms, *l1[3];
    vdbs_bake_report report;
} outputs;

static void outputs_free(outputs *o)
{
    free(o->radiance);
    free(o->ms);
    for (int a = 0; a < 3; ++a)
        free(o->l1[a]);
}

static int bake(const vdbs_volume *volume, const vdbs_scene *scene, outputs *o, char *why,
                size_t why_size)
{
    const size_t n = volume->coord_count;
    o->n = n;
    o->radiance = calloc(3 * n, sizeof(float));
    o->ms = calloc(3 * n, sizeof(float));
    for (int a = 0; a < 3; ++a)
        o->l1[a] = calloc(3 * n, sizeof(float));
    assert_true(o->radiance && o->ms && o->l1[0] && o->l1[1] && o->l1[2]);
    vdbs_bake_options opt = {0};
    opt.scene = scene;
    opt.backend = VDBS_BACKEND_CPU;
    vdbs_error err;
    if (vdbs_bake_volume(&opt, volume, o->radiance, o->ms, o->l1, &o->report, &err) != VDBS_OK) {
        snprintf(why, why_size, "%.400s", err.message);
        return 0;
    }
    return 1;
}

/* Relative difference of the scaled result from the scale-1 result times the factor, over
 * values whose scale-1 magnitude is a normal float well away from underflow (2^-100: scaled
 * by 2^-20 it stays normal). */
static double scale_error(const float *a, const float *b, size_t count, double factor, int *checked)
{
    double worst = 0.0;
    for (size_t i = 0; i < count; ++i) {
        if (fabsf(a[i]) < 0x1p-100f || fabsf(a[i]) > 0x1p100f)
            continue;
        ++*checked;
        const double want = (double)a[i] * factor;
        const double e = fabs((double)b[i] - want) / fabs(want);
        if (e > worst)
            worst = e;
    }
    return worst;
}

typedef struct case_desc {
    int volume, light, albedo, g, tau, scale;
    int boundary; /* 1: with the solver's choice "boundary" (boundary_option) */
} case_desc;

/* The solver's option with a choice "boundary", its index in *choice; NULL: none. */
static const vdbs_solver_option *boundary_option(const vdbs_solver *solver, int *choice)
{
    for (int i = 0; i < solver->option_count; ++i) {
        const vdbs_solver_option *o = &solver->options[i];
        for (int c = 0; o->kind == VDBS_OPTION_CHOICE && o->choices[c]; ++c)
            if (strcmp(o->choices[c], "boundary") == 0) {
                *choice = c;
                return o;
            }
    }
    return NULL;
}

/* The solver's choice "boundary" set in the scene; returns its option, NULL: none. */
static const vdbs_solver_option *set_boundary(const vdbs_solver *solver, vdbs_scene *scene)
{
    int choice = 0;
    const vdbs_solver_option *option = boundary_option(solver, &choice);
    vdbs_error err;
    if (option)
        assert_int_equal(vdbs_scene_solver_store(scene, option->key, choice, &err), VDBS_OK);
    return option;
}

/* The case's solver options into the scene. */
static void case_options(const case_desc *c, const vdbs_solver *solver, vdbs_scene *scene)
{
    if (c->boundary)
        set_boundary(solver, scene);
}

static void case_name(const case_desc *c, const vdbs_solver *solver, char *buf, size_t size)
{
    int choice = 0;
    const vdbs_solver_option *option = c->boundary ? boundary_option(solver, &choice) : NULL;
    snprintf(buf, size, "%s%s%s: %s, %s, albedo %g, g %g, tau/voxel %g, scale 2^%d", solver->name,
             option ? " " : "", option ? option->flag : "", VOL_NAMES[c->volume],
             LIGHT_NAMES[c->light], ALBEDOS[c->albedo], GS[c->g], TAUS[c->tau],
             (int)lround(log2(SCALES[c->scale])));
}

/* Exact scaling (bit for bit) is asserted for the solvers listed here, a solver not listed
 * to LINEAR_TOL relative. These four are homogeneous of degree one in the lights: their
 * stopping rules (SVD's and POP's residuals, FLD's CG tolerance) are relative, the limiter and
 * the clamps compare ratios, their sums run in a fixed order, and a power of two scales a
 * normal float exactly (docs/robustness.md "Extremes"; measured exact in every case). A
 * solver with an absolute threshold or epsilon would scale only to rounding. */
static const char *const EXACT_SCALING[] = {"single", "pop", "fld", "svd", NULL};
#define LINEAR_TOL 1e-5

static int exact_scaling(const vdbs_solver *solver)
{
    for (int i = 0; EXACT_SCALING[i]; ++i)
        if (strcmp(EXACT_SCALING[i], solver->name) == 0)
            return 1;
    return 0;
}

static void run_case(int si, const vdbs_solver *solver, const vdbs_volume *volume,
                     const case_desc *c)
{
    char name[256], why[512];
    case_name(c, solver, name, sizeof name);
    row_stats *rs = &STATS[si];
    ++rs->cases;
    box b;
    vdbs_volume_support_bounds(volume, b.lo, b.hi);
    vdbs_scene scene;
    make_scene(&scene, solver, c->light, ALBEDOS[c->albedo], GS[c->g], TAUS[c->tau], 1.0, &b,
               volume->mean_voxel_size);
    case_options(c, solver, &scene);
    outputs o;
    if (!bake(volume, &scene, &o, why, sizeof why)) {
        finding("%s: the bake failed: %s", name, why);
        ++rs->failures;
        outputs_free(&o);
        return;
    }
    const int before = FAILURES;
    const size_t n = o.n;
    const double g = GS[c->g];
    /* float rounding of the bound: relative 1e-4, plus 1e-6 of the channel's largest ms (the
     * moments are upsampled and summed apart from ms) */
    double ms_max[3] = {0.0, 0.0, 0.0};
    for (size_t i = 0; i < 3 * n; ++i)
        ms_max[i % 3] = fmax(ms_max[i % 3], (double)o.ms[i]);
    /* finite, non-negative; |ms_l1| <= 3 |g| ms (+ float rounding) */
    for (size_t v = 0; v < n; ++v)
        for (int ch = 0; ch < 3; ++ch) {
            const size_t i = 3 * v + ch;
            const float r = o.radiance[i], m = o.ms[i];
            const float lx = o.l1[0][i], ly = o.l1[1][i], lz = o.l1[2][i];
            if (!(isfinite(r) && r >= 0.0f) || !(isfinite(m) && m >= 0.0f) ||
                !(isfinite(lx) && isfinite(ly) && isfinite(lz))) {
                finding("%s: voxel %zu channel %d: radiance %g, ms %g, ms_l1 (%g, %g, %g)", name, v,
                        ch, r, m, lx, ly, lz);
                goto values_done;
            }
            const double len = sqrt((double)lx * lx + (double)ly * ly + (double)lz * lz);
            if (len > 3.0 * fabs(g) * m * (1.0 + 1e-4) + 1e-6 * ms_max[ch] + 1e-30) {
                finding("%s: voxel %zu channel %d: |ms_l1| %g > 3 |g| ms = %g", name, v, ch, len,
                        3.0 * fabs(g) * m);
                goto values_done;
            }
            if (r > rs->worst)
                rs->worst = r;
        }
values_done:;
    /* energy: 4 pi sum sigma_a radiance V <= entering power, per channel */
    double enter[3];
    entering_power(&scene, c->light, &b, enter);
    const double vv = vdbs_volume_voxel_volume(volume);
    for (int ch = 0; ch < 3; ++ch) {
        double absorbed = 0.0;
        for (size_t v = 0; v < n; ++v) {
            const float d = vdbio_density_value(volume->density, volume->coords + 3 * v);
            absorbed +=
                d * scene.density_scale * (1.0 - ALBEDOS[c->albedo]) * o.radiance[3 * v + ch];
        }
        absorbed *= 4.0 * PI * vv;
        const double ratio = absorbed / enter[ch];
        if (ratio > rs->energy)
            rs->energy = ratio;
        if (!(ratio <= 1.0 + 1e-6))
            finding("%s: channel %d absorbs %g of the %g that entered (ratio %g)", name, ch,
                    absorbed, enter[ch], ratio);
    }
    /* the solver's own balances and its iterations */
    const void *st = vdbs_bake_report_stats(&o.report);
    double x, y, z;
    if (report_value(solver, st, "balance", &x)) { /* svd: within 1e-4 (docs/methods/svd.md) */
        rs->balance = fmax(rs->balance, x);
        if (!(x <= 1e-4))
            finding("%s: svd balance %g > 1e-4", name, x);
    }
    if (report_value(solver, st, "absorbed", &x) && report_value(solver, st, "leaked", &y) &&
        report_value(solver, st, "source", &z) && z > 1e-30) {
        /* fld: source = absorbed + leaked (test_fld: 1e-6 relative); a source below 1e-30 (a
         * point light behind 1e4 per voxel: 2e-52) underflows the float fluence to 0, and
         * its relative balance says nothing */
        const double e = fabs(x + y - z) / z;
        rs->balance = fmax(rs->balance, e);
        if (!(e <= 1e-6))
            finding("%s: fld absorbed %g + leaked %g vs source %g (%g relative)", name, x, y, z, e);
    }
    if (report_value(solver, st, "merge_in", &x) && report_value(solver, st, "merge_out", &y) &&
        x > 0.0) {
        /* pop: the merge keeps its energy up to rounding */
        const double e = fabs(x - y) / x;
        rs->balance = fmax(rs->balance, e);
        if (!(e <= 1e-5))
            finding("%s: pop merge in %g, out %g (%g relative)", name, x, y, e);
    }
    if (report_value(solver, st, "iterations", &x)) {
        const double cap = option_value(solver, &scene, "_iterations");
        const double requested = option_value(solver, &scene, "_residual");
        double conv = 1.0, res = 0.0;
        const int has_conv = report_value(solver, st, "converged", &conv);
        report_value(solver, st, "residual", &res);
        if (cap > 0.0) {
            rs->iter_ratio = fmax(rs->iter_ratio, x / cap);
            if (x > rs->iterations)
                rs->iterations = (int)x, rs->cap = (int)cap;
            if (x > cap)
                finding("%s: %g iterations over the cap %g", name, x, cap);
        }
        if (has_conv && conv != 0.0 && requested > 0.0 && !(res <= requested))
            finding("%s: reported converged with residual %g > requested %g", name, res, requested);
        /* Stopping short of the cap, not converged, is truthful only where the solver's own
         * estimate said the cap would come first. */
        double predicted = 0.0;
        const int has_predicted = report_value(solver, st, "predicted_iterations", &predicted);
        if (has_conv && conv == 0.0 && cap > 0.0 && x < cap && !(has_predicted && predicted > cap))
            finding("%s: not converged after %g of %g iterations", name, x, cap);
    }
    if (report_value(solver, st, "iterations_anisotropic", &x) &&
        report_value(solver, st, "resolution", &y)) {
        /* pop: Eq. 10's count, at most max(64, 4 x res) unless the option caps it */
        double cap = option_value(solver, &scene, "_iterations");
        if (cap <= 0.0)
            cap = fmax(64.0, 4.0 * y);
        rs->iter_ratio = fmax(rs->iter_ratio, x / cap);
        if (x / cap >= rs->iter_ratio)
            rs->iterations = (int)x, rs->cap = (int)cap;
        if (x > cap)
            finding("%s: %g anisotropic iterations over the cap %g", name, x, cap);
    }
    /* light scale */
    if (SCALES[c->scale] != 1.0) {
        const double f = SCALES[c->scale];
        vdbs_scene scaled;
        make_scene(&scaled, solver, c->light, ALBEDOS[c->albedo], g, TAUS[c->tau], f, &b,
                   volume->mean_voxel_size);
        case_options(c, solver, &scaled);
        outputs p;
        if (!bake(volume, &scaled, &p, why, sizeof why)) {
            finding("%s: the scaled bake failed: %s", name, why);
        } else {
            int checked = 0;
            double e = scale_error(o.radiance, p.radiance, 3 * n, f, &checked);
            e = fmax(e, scale_error(o.ms, p.ms, 3 * n, f, &checked));
            for (int a = 0; a < 3; ++a)
                e = fmax(e, scale_error(o.l1[a], p.l1[a], 3 * n, f, &checked));
            rs->linearity = fmax(rs->linearity, e);
            if (exact_scaling(solver) ? e != 0.0 : !(e <= LINEAR_TOL))
                finding("%s: scaled result off by %g relative (%s)", name, e,
                        exact_scaling(solver) ? "bit-exact expected" : "tolerance 1e-5");
        }
        outputs_free(&p);
    }
    if (FAILURES > before)
        ++rs->failures;
    outputs_free(&o);
}

/* Greedy pairwise covering array over AXES: each new row starts from the first uncovered
 * pair and fills every other axis with the value that covers the most uncovered pairs (ties:
 * the smallest value). Deterministic. Returns the row count. */
static int covering_array(int rows[MAX_ROWS][AXES])
{
    static unsigned char covered[AXES][8][AXES][8];
    memset(covered, 0, sizeof covered);
    int count = 0;
    for (;;) {
        int fa = -1, fv = -1, fb = -1, fw = -1;
        for (int a = 0; a < AXES && fa < 0; ++a)
            for (int b = a + 1; b < AXES && fa < 0; ++b)
                for (int v = 0; v < AXIS_SIZE[a] && fa < 0; ++v)
                    for (int w = 0; w < AXIS_SIZE[b] && fa < 0; ++w)
                        if (!covered[a][v][b][w])
                            fa = a, fv = v, fb = b, fw = w;
        if (fa < 0)
            break;
        assert_true(count < MAX_ROWS);
        int *row = rows[count++];
        int set[AXES] = {0};
        row[fa] = fv, row[fb] = fw;
        set[fa] = set[fb] = 1;
        for (int a = 0; a < AXES; ++a) {
            if (set[a])
                continue;
            int best = 0, best_gain = -1;
            for (int v = 0; v < AXIS_SIZE[a]; ++v) {
                int gain = 0;
                for (int b = 0; b < AXES; ++b) {
                    if (!set[b])
                        continue;
                    gain += a < b ? !covered[a][v][b][row[b]] : !covered[b][row[b]][a][v];
                }
                if (gain > best_gain)
                    best_gain = gain, best = v;
            }
            row[a] = best;
            set[a] = 1;
        }
        for (int a = 0; a < AXES; ++a)
            for (int b = a + 1; b < AXES; ++b)
                covered[a][row[a]][b][row[b]] = 1;
    }
    return count;
}

static int FULL;

static void test_covering_array(void **state)
{
    (void)state;
    int rows[MAX_ROWS][AXES];
    const int count = covering_array(rows);
    /* every pair of values of any two axes in some row, counted independently of the
     * construction's own bookkeeping */
    long pairs = 0;
    for (int a = 0; a < AXES; ++a)
        for (int b = a + 1; b < AXES; ++b)
            for (int v = 0; v < AXIS_SIZE[a]; ++v)
                for (int w = 0; w < AXIS_SIZE[b]; ++w) {
                    int found = 0;
                    for (int r = 0; r < count && !found; ++r)
                        found = rows[r][a] == v && rows[r][b] == w;
                    if (!found)
                        fail_msg("pair axis %d = %d, axis %d = %d in no row", a, v, b, w);
                    ++pairs;
                }
    for (int r = 0; r < count; ++r)
        for (int a = 0; a < AXES; ++a)
            assert_true(rows[r][a] >= 0 && rows[r][a] < AXIS_SIZE[a]);
    /* the largest two axes alone need 8 x 5 rows; greedy stays within 1.5x of that */
    print_message("covering array: %d rows, %ld pairs\n", count, pairs);
    assert_true(count >= 8 * 5 && count <= 60);
}

static int solver_count(void)
{
    int n = 0;
    while (vdbs_solver_at(n))
        ++n;
    assert_true(n >= 4 && n <= MAX_SOLVERS);
    return n;
}

/* VDBSCATTER_EXTREMES_SOLVERS=a,b: the matrix and the furnace for these solvers only, =-a,b for
 * every solver but these (ctest runs the slice in two processes, inet's alone: its sweeps are
 * most of the time); unset or empty: every solver. */
static int solver_selected(const vdbs_solver *solver)
{
    const char *list = getenv("VDBSCATTER_EXTREMES_SOLVERS");
    if (!list || !list[0])
        return 1;
    const int except = list[0] == '-';
    const size_t len = strlen(solver->name);
    for (const char *p = list + except; *p;) {
        const char *end = strchr(p, ',');
        const size_t n = end ? (size_t)(end - p) : strlen(p);
        if (n == len && strncmp(p, solver->name, n) == 0)
            return !except;
        p += n + (end ? 1 : 0);
    }
    return except;
}

static int corner(int i, int n)
{
    return i == 0 || i == n - 1;
}

/* Points of the grid (albedo, g, thickness indices) where a solver once created energy, in
 * the slice too (docs/robustness.md "Extremes"): POP's light splatted from vacuum and over
 * the lit skin of a cube thick in absorption; SVD's delta-M beam read through depths past the
 * march's limit. */
static const int FORMER_FINDINGS[][3] = {{1, 3, 4}, {2, 3, 4}, {2, 4, 4},
                                         {2, 7, 3}, {2, 7, 4}, {3, 7, 4}};

static int former_finding(int a, int g, int t)
{
    for (size_t i = 0; i < sizeof FORMER_FINDINGS / sizeof FORMER_FINDINGS[0]; ++i)
        if (FORMER_FINDINGS[i][0] == a && FORMER_FINDINGS[i][1] == g && FORMER_FINDINGS[i][2] == t)
            return 1;
    return 0;
}

static void test_grid(void **state)
{
    (void)state;
    vdbs_volume cube;
    make_volume(VOL_CUBE, &cube);
    const int solvers = solver_count();
    for (int s = 0; s < solvers; ++s) {
        const vdbs_solver *solver = vdbs_solver_at(s);
        if (!solver_selected(solver))
            continue;
        for (int a = 0; a < N_ALBEDO; ++a)
            for (int g = 0; g < N_G; ++g)
                for (int t = 0; t < N_TAU; ++t) {
                    if (!FULL && !(corner(a, N_ALBEDO) && corner(g, N_G) && corner(t, N_TAU)) &&
                        !former_finding(a, g, t))
                        continue;
                    case_desc c = {VOL_CUBE, LIGHT_SUN, a, g, t, 1, 0};
                    run_case(s, solver, &cube, &c);
                }
    }
    vdbs_volume_free(&cube);
}

static void test_covering_cases(void **state)
{
    (void)state;
    int rows[MAX_ROWS][AXES];
    const int count = covering_array(rows);
    vdbs_volume volumes[VOL_KINDS];
    for (int k = 0; k < VOL_KINDS; ++k)
        make_volume(k, &volumes[k]);
    const int solvers = solver_count();
    for (int s = 0; s < solvers; ++s) {
        const vdbs_solver *solver = vdbs_solver_at(s);
        if (!solver_selected(solver))
            continue;
        for (int r = 0; r < count; ++r) {
            const int *row = rows[r];
            if (!FULL && row[AX_VOL] == VOL_CLOUD)
                continue;
            case_desc c = {row[AX_VOL],
                           row[AX_LIGHT],
                           row[AX_ALBEDO],
                           row[AX_G],
                           row[AX_TAU],
                           row[AX_SCALE],
                           0};
            run_case(s, solver, &volumes[c.volume], &c);
            /* A sky's uniform part through the grid's boundary too, where a solver offers it. */
            int choice = 0;
            c.boundary = 1;
            if ((c.light == LIGHT_SKY || c.light == LIGHT_ENV) && boundary_option(solver, &choice))
                run_case(s, solver, &volumes[c.volume], &c);
        }
    }
    for (int k = 0; k < VOL_KINDS; ++k)
        vdbs_volume_free(&volumes[k]);
}

/* The reference path tracer at the corners of albedo, g and thickness (the 8^3 cube, a sun
 * and a sky; it has no env maps): finite, non-negative pixels. */
static void test_reference_corners(void **state)
{
    (void)state;
    vdbs_volume cube;
    make_volume(VOL_CUBE, &cube);
    box b;
    vdbs_volume_support_bounds(&cube, b.lo, b.hi);
    const vdbs_solver *solver = vdbs_solver_at(0);
    const int size = 8;
    vdbs_camera camera;
    vdbs_camera_frame_volume(&cube, size, size, &camera);
    vdbs_camera_frame frame;
    vdbs_error err;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_image image;
    assert_int_equal(vdbs_image_alloc(&image, size, size, 1, &err), VDBS_OK);
    int renders = 0;
    for (int a = 0; a < N_ALBEDO; a += N_ALBEDO - 1)
        for (int g = 0; g < N_G; g += N_G - 1)
            for (int t = 0; t < N_TAU; t += N_TAU - 1)
                for (int light = LIGHT_SUN; light <= LIGHT_SKY; light += LIGHT_SKY) {
                    vdbs_scene scene;
                    make_scene(&scene, solver, light, ALBEDOS[a], GS[g], TAUS[t], 1.0, &b,
                               cube.mean_voxel_size);
                    vdbs_reference_options options = {0};
                    options.spp = 4;
                    options.max_bounces = 64;
                    options.seed = 11;
                    if (vdbs_reference_render(&cube, &scene, &frame, &options, &image, NULL,
                                              &err) != VDBS_OK)
                        fail_msg("reference: %s", err.message);
                    for (int i = 0; i < 3 * size * size; ++i)
                        if (!(isfinite(image.rgb[i]) && image.rgb[i] >= 0.0f &&
                              isfinite(image.se[i]) && image.se[i] >= 0.0f))
                            finding("reference: %s, albedo %g, g %g, tau/voxel %g: pixel value "
                                    "%d is %g (se %g)",
                                    LIGHT_NAMES[light], ALBEDOS[a], GS[g], TAUS[t], i, image.rgb[i],
                                    image.se[i]);
                    ++renders;
                }
    print_message("reference: %d corner renders\n", renders);
    vdbs_image_free(&image);
    vdbs_volume_free(&cube);
}

/* ---- the white furnace ----
 * At albedo 1 under a uniform sky of radiance 1 and no other light, the exact in-scattered
 * radiance is 1 at every voxel, whatever the density and g. Over the voxels whose density is
 * above 0.05 of the largest: the target at high is a mean within 2% of 1 and the 1st to 99th
 * percentiles within 5% (inet runs at low). A solver with a choice "boundary" among its options (the sky's
 * uniform part through its grid's boundary, skyfloor.h: FLD's and SVD's --*-sky) is held to
 * it with that choice, and measured and printed at its defaults (which bring the whole sky in
 * as first collisions, measured better on images: docs/robustness.md "White furnace"); any
 * other solver is held to it at its defaults, POP and INET only measured: their bias is their
 * published methods' (POP's transit loss; the network's particles of finite opacity in pixel
 * columns, whose extinction is not the medium's: docs/methods/inet.md "White furnace"). With
 * its own first scattering the network is exact in the furnace (tests/test_inet.c). */
static const char *const FURNACE_MEASURED_ONLY[] = {"pop", "inet", NULL};
static const double FURNACE_GS[] = {0.0, 0.5, 0.9};

/* One case; `held`: 1 when it is held to the target, 0 when only printed. */
static void furnace_case(const vdbs_solver *solver, int boundary, int held, int kind,
                         const vdbs_volume *volume, double g)
{
    box b;
    vdbs_volume_support_bounds(volume, b.lo, b.hi);
    vdbs_scene scene;
    make_scene(&scene, solver, LIGHT_SKY, 1.0, g, 1.0, 1.0, &b, volume->mean_voxel_size);
    /* inet measured at low: its figures printed at a fraction of high's time (its particles). */
    snprintf(scene.quality, sizeof scene.quality, "%s",
             strcmp(solver->name, "inet") == 0 ? "low" : "high");
    for (int c = 0; c < 3; ++c)
        scene.lights[0].color[c] = 1.0;
    const vdbs_solver_option *option = boundary ? set_boundary(solver, &scene) : NULL;
    char name[160];
    snprintf(name, sizeof name, "%s%s%s %s g %g", solver->name, option ? " " : "",
             option ? option->flag : "", VOL_NAMES[kind], g);
    outputs o;
    char why[512];
    if (!bake(volume, &scene, &o, why, sizeof why)) {
        finding("furnace %s: the bake failed: %s", name, why);
        outputs_free(&o);
        return;
    }
    double dmax = 0.0;
    for (size_t v = 0; v < o.n; ++v)
        dmax = fmax(dmax, vdbio_density_value(volume->density, volume->coords + 3 * v));
    double *r = malloc(sizeof(double) * o.n);
    assert_non_null(r);
    size_t n = 0, worst = 0;
    double sum = 0.0, worst_off = -1.0;
    for (size_t v = 0; v < o.n; ++v) {
        if (vdbio_density_value(volume->density, volume->coords + 3 * v) <= 0.05 * dmax)
            continue;
        r[n] = o.radiance[3 * v + 1];
        if (fabs(r[n] - 1.0) > worst_off) {
            worst_off = fabs(r[n] - 1.0);
            worst = v;
        }
        sum += r[n++];
    }
    assert_true(n > 0);
    qsort(r, n, sizeof *r, test_compare_doubles);
    const double mean = sum / (double)n, p1 = r[n / 100], p99 = r[n - 1 - n / 100];
    const int32_t *w = volume->coords + 3 * worst;
    print_message("furnace %s: mean %.4f p1 %.4f p99 %.4f, worst %.4f at (%d %d %d): "
                  "density %.3f of %.3f, S1 %.4f, ms %.4f%s\n",
                  name, mean, p1, p99, o.radiance[3 * worst + 1], w[0], w[1], w[2],
                  vdbio_density_value(volume->density, w), dmax,
                  o.radiance[3 * worst + 1] - o.ms[3 * worst + 1], o.ms[3 * worst + 1],
                  held ? "" : " (measured only)");
    if (held && (fabs(mean - 1.0) > 0.02 || p1 < 0.95 || p99 > 1.05))
        finding("furnace %s: mean %.4f, p1 %.4f, p99 %.4f (target: mean within 2%%, p1 to p99 "
                "within 5%%)",
                name, mean, p1, p99);
    free(r);
    outputs_free(&o);
}

static void test_white_furnace(void **state)
{
    (void)state;
    const int before = FAILURES;
    const int kinds[] = {VOL_CUBE, VOL_CLOUD};
    int held = 0;
    for (int k = 0; k < 2; ++k) {
        vdbs_volume volume;
        make_volume(kinds[k], &volume);
        for (int s = 0; vdbs_solver_at(s); ++s) {
            const vdbs_solver *solver = vdbs_solver_at(s);
            if (!solver->writes_ms || !solver_selected(solver))
                continue;
            int measured_only = 0, choice = 0;
            for (int i = 0; FURNACE_MEASURED_ONLY[i]; ++i)
                measured_only |= strcmp(solver->name, FURNACE_MEASURED_ONLY[i]) == 0;
            const vdbs_solver_option *option = boundary_option(solver, &choice);
            for (size_t gi = 0; gi < sizeof FURNACE_GS / sizeof *FURNACE_GS; ++gi) {
                furnace_case(solver, 0, !measured_only && !option, kinds[k], &volume,
                             FURNACE_GS[gi]);
                if (option)
                    furnace_case(solver, 1, !measured_only, kinds[k], &volume, FURNACE_GS[gi]);
                held += !measured_only;
            }
        }
        vdbs_volume_free(&volume);
    }
    /* FLD and SVD at least (solver.h's table): a furnace that holds nothing proves nothing. */
    assert_true(held >= 12);
    if (FAILURES > before)
        fail_msg("%d furnace cases miss the target", FAILURES - before);
}

static void write_table(const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f)
        fail_msg("cannot write %s", path);
    fprintf(f,
            "# Extremes matrix (%s)\n\n"
            "Written by `VDBSCATTER_EXTREMES_TABLE=PATH build/tests/test_extremes%s` "
            "(tests/test_extremes.c; docs/robustness.md \"Extremes\"). Quality low, C path.\n\n",
            FULL ? "full" : "slice", FULL ? " full" : "");
    fprintf(f,
            "| solver | cases | worst absorbed/entered | worst own balance | "
            "iterations / cap (worst) | worst scaling error | largest radiance | failing cases |\n"
            "|---|---:|---:|---:|---:|---:|---:|---:|\n");
    const int solvers = solver_count();
    for (int s = 0; s < solvers; ++s) {
        const row_stats *r = &STATS[s];
        char iter[64] = "-";
        if (r->cap > 0)
            snprintf(iter, sizeof iter, "%d / %d", r->iterations, r->cap);
        fprintf(f, "| %s | %d | %.3g | %.3g | %s | %.3g | %.3g | %d |\n", vdbs_solver_at(s)->name,
                r->cases, r->energy, r->balance, iter, r->linearity, r->worst, r->failures);
    }
    fclose(f);
}

static void test_verdict(void **state)
{
    (void)state;
    const char *table = getenv("VDBSCATTER_EXTREMES_TABLE");
    if (table && table[0])
        write_table(table);
    const int solvers = solver_count();
    for (int s = 0; s < solvers; ++s)
        print_message("%s: %d cases, worst energy %.3g, balance %.3g, iterations %d / %d, "
                      "scaling %.3g, largest %.3g, %d failing\n",
                      vdbs_solver_at(s)->name, STATS[s].cases, STATS[s].energy, STATS[s].balance,
                      STATS[s].iterations, STATS[s].cap, STATS[s].linearity, STATS[s].worst,
                      STATS[s].failures);
    if (FAILURES)
        fail_msg("%d findings; the first: %s", FAILURES, FIRST_FAILURE);
}

int main(int argc, char **argv)
{
    FULL = argc > 1 && strcmp(argv[1], "full") == 0;
    /* VDBSCATTER_EXTREMES_ONLY / _SKIP=PATTERN: run only / skip the tests it matches (cmocka's
     * patterns: * and ?). */
    const char *only = getenv("VDBSCATTER_EXTREMES_ONLY"),
               *skip = getenv("VDBSCATTER_EXTREMES_SKIP");
    if (only && only[0])
        cmocka_set_test_filter(only);
    if (skip && skip[0])
        cmocka_set_skip_filter(skip);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_covering_array), cmocka_unit_test(test_grid),
        cmocka_unit_test(test_covering_cases), cmocka_unit_test(test_reference_corners),
        cmocka_unit_test(test_white_furnace),  cmocka_unit_test(test_verdict),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    test_runners_free();
    return rc;
}
