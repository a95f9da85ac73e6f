#include "vdbscatter/reference.h"

#include "vdbscatter/lights.h"

#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vdbscatter/medium.h"
#include "base/vdbs_math.h"
#include "render/image_check.h"
#include "vs_common.h"
#include "vs_march.h"
#include "vs_phase.h"

/* Tracking steps one path may take in total (see the header's note on guards). */
#define REF_PATH_STEPS (1 << 22)
/* Russian roulette starts after this many scattering events. */
#define REF_RR_START 3
/* Ratio tracking plays roulette once the transmittance estimate falls below this. */
#define REF_RATIO_RR 0.05
/* Paths per deterministic chunk of the energy tally. */
#define REF_TALLY_CHUNK 4096

/* ---- random numbers: a counter-based hash of (seed, stream, index) and a counter ---- */

typedef struct ref_rng {
    uint64_t key;
    uint64_t counter;
} ref_rng;

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static ref_rng rng_make(uint64_t seed, uint64_t stream, uint64_t index)
{
    ref_rng r;
    uint64_t k = mix64(seed + 0x9e3779b97f4a7c15ull);
    k = mix64(k ^ (stream * 0xd1b54a32d192ed03ull + 0x8cb92ba72f3d8dd7ull));
    k = mix64(k ^ (index * 0xa0761d6478bd642full + 0xe7037ed1a0b428dbull));
    r.key = k;
    r.counter = 0;
    return r;
}

/* Uniform in [0, 1). Hashing the counter before adding the key keeps streams of
 * different keys from being shifted copies of each other. */
static double rng_next(ref_rng *r)
{
    uint64_t x = mix64(r->key + mix64(++r->counter));
    return (double)(x >> 11) * 0x1.0p-53;
}

/* Exponential with mean 1 (1 - u is in (0, 1], so the log is finite). */
static double rng_exp(ref_rng *r)
{
    return -log(1.0 - rng_next(r));
}

/* ---- Henyey-Greenstein (shaders/vs_phase.h) ---- */

double vdbs_reference_hg_sample(double g, double u)
{
    double mu, s;
    vs_hg_sample_d(g, u, &mu, &s);
    return mu;
}

/* 1 - a.b for unit vectors as |a - b|^2 / 2. */
static double one_minus_dot(const double a[3], const double b[3])
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return 0.5 * (x * x + y * y + z * z);
}

static void normalize3(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (len > 0.0)
        for (int a = 0; a < 3; ++a)
            v[a] /= len;
}

/* Turns the unit vector w by an angle of cosine mu at azimuth 2 pi u. */
static void scatter_dir(double w[3], double mu, double sin_theta, double u)
{
    double t1[3], t2[3];
    vdbs_ortho_basis(w, t1, t2);
    double phi = 2.0 * VDBS_PI * u;
    double c = sin_theta * cos(phi), s = sin_theta * sin(phi);
    double out[3];
    for (int k = 0; k < 3; ++k)
        out[k] = c * t1[k] + s * t2[k] + mu * w[k];
    normalize3(out);
    memcpy(w, out, sizeof out);
}

/* ---- tracking ---- */

typedef struct ref_tracker {
    const vdbs_majorant_grid *grid;
    pnanovdb_buf_t buf;
    pnanovdb_readaccessor_t acc;
    double density_scale;
    int64_t budget; /* tracking steps left for the current path */
} ref_tracker;

static double sigma_at(ref_tracker *tr, const double o[3], const double d[3], double t)
{
    pnanovdb_vec3_t p =
        vs_vec3((float)(o[0] + d[0] * t), (float)(o[1] + d[1] * t), (float)(o[2] + d[2] * t));
    return vs_density_at(tr->buf, &tr->acc, p) * tr->density_scale;
}

enum { TRACK_ESCAPED = 0, TRACK_COLLIDED = 1, TRACK_GAVE_UP = 2 };

/* Both trackers walk the majorant cells that the ray o + t d, t in [0, tmax], crosses. The
 * walk starts here: 0 when the ray misses the support box, else *exit_axis is the face it
 * leaves through. */
static int walk_begin(const ref_tracker *tr, const double o[3], const double d[3], double tmax,
                      vdbs_majorant_dda *s, int *exit_axis)
{
    double t0, t1;
    if (!vdbs_majorant_grid_clip(tr->grid, o, d, tmax, &t0, &t1, exit_axis))
        return 0;
    vdbs_majorant_dda_init(s, tr->grid, o, d, t0, t1);
    return 1;
}

/* The walk's next segment [*ta, *tb] with a positive majorant *mu (the others hold no
 * collision); 0 at the end of the ray. */
static int walk_next(vdbs_majorant_dda *s, double *ta, double *tb, double *mu)
{
    while (vdbs_majorant_dda_next(s, ta, tb, mu))
        if (*mu > 0.0)
            return 1;
    return 0;
}

/* Delta tracking from index point o along d (index image of a unit world step) for
 * t in [0, tmax]: the first real collision, or escape through face *exit_axis (-1 when
 * the ray never meets the support box). */
static int delta_track(ref_tracker *tr, ref_rng *rng, const double o[3], const double d[3],
                       double tmax, double *t_hit, int *exit_axis)
{
    vdbs_majorant_dda s;
    if (!walk_begin(tr, o, d, tmax, &s, exit_axis)) {
        *exit_axis = -1;
        return TRACK_ESCAPED;
    }
    double tau = rng_exp(rng);
    double ta, tb, mu;
    while (walk_next(&s, &ta, &tb, &mu)) {
        double t = ta;
        for (;;) {
            if (--tr->budget < 0)
                return TRACK_GAVE_UP;
            double dt = tau / mu;
            if (t + dt >= tb) {
                tau -= mu * (tb - t);
                break;
            }
            t += dt;
            if (rng_next(rng) * mu < sigma_at(tr, o, d, t)) {
                *t_hit = t;
                return TRACK_COLLIDED;
            }
            tau = rng_exp(rng);
        }
    }
    return TRACK_ESCAPED;
}

/* Ratio tracking: an unbiased estimate of the transmittance over t in [0, tmax], with
 * roulette once it is small so that thick media end the walk early. */
static double ratio_track(ref_tracker *tr, ref_rng *rng, const double o[3], const double d[3],
                          double tmax)
{
    vdbs_majorant_dda s;
    int axis;
    if (!walk_begin(tr, o, d, tmax, &s, &axis))
        return 1.0;
    double transmittance = 1.0;
    double ta, tb, mu;
    while (walk_next(&s, &ta, &tb, &mu)) {
        double t = ta;
        for (;;) {
            if (--tr->budget < 0)
                return 0.0;
            t += rng_exp(rng) / mu;
            if (t >= tb)
                break;
            transmittance *= fmax(0.0, 1.0 - sigma_at(tr, o, d, t) / mu);
            if (transmittance < REF_RATIO_RR) {
                if (rng_next(rng) * REF_RATIO_RR >= transmittance)
                    return 0.0;
                transmittance = REF_RATIO_RR;
            }
        }
    }
    return transmittance;
}

/* ---- scene setup ---- */

typedef struct ref_ctx {
    const vdbs_volume *volume;
    vdbs_medium medium;
    vdbs_majorant_grid grid;
    pnanovdb_buf_t buf;
    vdbs_light_table lights; /* suns and points; the sky is sampled here, not by ordinates */
    vdbs_envmap_sampler env; /* the map's distribution when lights.env is set */
    int max_bounces;
} ref_ctx;

static void ctx_free(ref_ctx *ctx)
{
    vdbs_majorant_grid_free(&ctx->grid);
    vdbs_envmap_sampler_free(&ctx->env);
    vdbs_lights_free(&ctx->lights);
    memset(ctx, 0, sizeof *ctx);
}

/* env_nee 0: the map is left to HG sampling (no sampler: no NEE, escape weights 1). */
static vdbs_status ctx_init(const vdbs_volume *volume, const vdbs_scene *scene, int max_bounces,
                            int env_nee, ref_ctx *ctx, vdbs_error *err)
{
    memset(ctx, 0, sizeof *ctx);
    if (max_bounces < 1)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "reference: max_bounces must be >= 1 (got %d)",
                              max_bounces);
    vdbs_status st = vdbs_lights_build(volume, scene, NULL, &ctx->lights, err);
    if (st != VDBS_OK)
        return st;
    ctx->volume = volume;
    ctx->buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    vdbs_medium_init(&ctx->medium, volume, scene);
    ctx->max_bounces = max_bounces;
    if (ctx->lights.env && env_nee &&
        (st = vdbs_envmap_sampler_init(ctx->lights.env, &ctx->env, err)) != VDBS_OK) {
        ctx_free(ctx);
        return st;
    }
    st = vdbs_majorant_grid_build(&ctx->medium, &ctx->grid, err);
    if (st != VDBS_OK)
        ctx_free(ctx);
    return st;
}

/* A world-space sphere holding the majorant grid's support box: its centre and the
 * half-diagonal of the box's world-space bounding box. */
static void support_sphere(const ref_ctx *ctx, double centre[3], double *radius)
{
    double ci[3], half[3], r2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        ci[a] = 0.5 * (ctx->grid.lo[a] + ctx->grid.hi[a]);
        half[a] = 0.5 * (ctx->grid.hi[a] - ctx->grid.lo[a]);
    }
    vdbs_volume_world_point(ctx->volume, ci, centre);
    for (int r = 0; r < 3; ++r) {
        double e = 0.0;
        for (int a = 0; a < 3; ++a)
            e += fabs(ctx->volume->index_to_world[r][a]) * half[a];
        r2 += e * e;
    }
    *radius = sqrt(r2);
}

static void tracker_init(const ref_ctx *ctx, ref_tracker *tr)
{
    tr->grid = &ctx->grid;
    tr->buf = ctx->buf;
    tr->acc = vs_density_accessor(ctx->buf);
    tr->density_scale = ctx->medium.density_scale;
    tr->budget = REF_PATH_STEPS;
}

/* ---- paths ---- */

/* The sky's radiance arriving from world direction `from` (unit): the constant env colours
 * plus the map, as the background (bilinear) for camera rays that leave unscattered, as
 * lighting (its texels, envmap.h) after a scattering. */
static void sky_radiance(const ref_ctx *ctx, const double from[3], int lighting, double out[3])
{
    memcpy(out, ctx->lights.sky, sizeof ctx->lights.sky);
    if (ctx->lights.env) {
        double m[3];
        if (lighting)
            vdbs_envmap_texel(ctx->lights.env, from, m);
        else
            vdbs_envmap_lookup(ctx->lights.env, from, m);
        for (int c = 0; c < 3; ++c)
            out[c] += m[c];
    }
}

/* Multiple importance sampling of a map (power heuristic): the weight of the strategy whose
 * pdf is a against the other's b. */
static double mis_weight(double a, double b)
{
    return a * a / (a * a + b * b);
}

/* The MIS weight of the sky seen along a phase-sampled direction w (the sky lies along w)
 * whose HG pdf was phase_pdf, against the map's next-event estimate that could have drawn w
 * too; 1 without a map. */
static double escape_weight(const ref_ctx *ctx, const double w[3], double phase_pdf)
{
    if (!(ctx->env.total > 0.0) || phase_pdf < 0.0)
        return 1.0;
    return mis_weight(phase_pdf, vdbs_envmap_sampler_pdf(&ctx->env, w));
}

/* Light arriving at the scattering vertex (world xw, index xi) and scattered into the
 * direction -w (towards where the path came from), per unit sigma_s: the NEE estimate of
 * S(x, -w) for the suns and point lights. */
static void next_event(const ref_ctx *ctx, ref_tracker *tr, ref_rng *rng, const double xw[3],
                       const double xi[3], const double w[3], double out[3])
{
    out[0] = out[1] = out[2] = 0.0;
    for (int i = 0; i < ctx->lights.direct_count; ++i) {
        const vdbs_direct_light *l = &ctx->lights.direct[i];
        double weight, transmittance;
        if (l->type == VDBS_LIGHT_SUN) {
            /* Incident propagation s, outgoing -w: 1 - mu = |s + w|^2 / 2. */
            double neg_w[3] = {-w[0], -w[1], -w[2]};
            weight = vs_hg_eval_d(ctx->medium.g, one_minus_dot(l->world, neg_w));
            transmittance = ratio_track(tr, rng, xi, l->index, HUGE_VAL);
        } else {
            double v[3] = {l->world[0] - xw[0], l->world[1] - xw[1], l->world[2] - xw[2]};
            double r = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            double rc = fmax(r, ctx->lights.min_distance);
            if (r > 0.0) {
                for (int a = 0; a < 3; ++a)
                    v[a] /= r;
                /* Incident propagation -v, outgoing -w: 1 - mu = |v - w|^2 / 2. */
                weight = vs_hg_eval_d(ctx->medium.g, one_minus_dot(v, w)) / (rc * rc);
                double d[3];
                vdbs_volume_index_vector(ctx->volume, v, d);
                transmittance = ratio_track(tr, rng, xi, d, r);
            } else {
                weight = 1.0 / (4.0 * VDBS_PI * rc * rc);
                transmittance = 1.0;
            }
        }
        for (int c = 0; c < 3; ++c)
            out[c] += l->color[c] * weight * transmittance;
    }
    if (!(ctx->env.total > 0.0))
        return;
    /* The map by its luminance x solid angle distribution, MIS-weighted against HG sampling
     * (which finds the same light on escape, weighted by escape_weight). */
    double from[3], texel[3], L[3];
    double pdf = vdbs_envmap_sampler_draw(&ctx->env, rng_next(rng), rng_next(rng), from, texel);
    double neg_from[3] = {-from[0], -from[1], -from[2]}, neg_w[3] = {-w[0], -w[1], -w[2]};
    double phase = vs_hg_eval_d(ctx->medium.g, one_minus_dot(neg_from, neg_w));
    double d[3];
    vdbs_volume_index_vector(ctx->volume, from, d);
    double transmittance = ratio_track(tr, rng, xi, d, HUGE_VAL);
    sky_radiance(ctx, from, 1, L);
    double weight = phase * transmittance * mis_weight(pdf, phase) / pdf;
    for (int c = 0; c < 3; ++c)
        out[c] += L[c] * weight;
}

/* One radiance sample along the camera ray (world origin and unit direction). */
static void trace_camera(const ref_ctx *ctx, ref_tracker *tr, ref_rng *rng, const double org[3],
                         const double dir[3], double radiance[3])
{
    double beta[3] = {1.0, 1.0, 1.0};
    double xw[3], xi[3], w[3], d[3];
    memcpy(xw, org, sizeof xw);
    memcpy(w, dir, sizeof w);
    vdbs_volume_index_point(ctx->volume, xw, xi);
    vdbs_volume_index_vector(ctx->volume, w, d);
    radiance[0] = radiance[1] = radiance[2] = 0.0;
    tr->budget = REF_PATH_STEPS;
    double phase_pdf = -1.0; /* HG pdf of the current direction; < 0: the camera's own */

    for (int bounce = 1;; ++bounce) {
        double t;
        int axis;
        int r = delta_track(tr, rng, xi, d, HUGE_VAL, &t, &axis);
        if (r == TRACK_ESCAPED) {
            if (ctx->lights.has_sky) {
                double L[3], weight = escape_weight(ctx, w, phase_pdf);
                sky_radiance(ctx, w, phase_pdf >= 0.0, L);
                for (int c = 0; c < 3; ++c)
                    radiance[c] += beta[c] * L[c] * weight;
            }
            return;
        }
        if (r == TRACK_GAVE_UP)
            return;
        for (int a = 0; a < 3; ++a) {
            xw[a] += w[a] * t;
            xi[a] += d[a] * t;
        }
        /* Analog collision: always scatter, weighted by the albedo sigma_s / sigma_t. */
        for (int c = 0; c < 3; ++c)
            beta[c] *= ctx->medium.albedo[c];
        double bmax = fmax(beta[0], fmax(beta[1], beta[2]));
        if (!(bmax > 0.0))
            return;
        double s[3];
        next_event(ctx, tr, rng, xw, xi, w, s);
        for (int c = 0; c < 3; ++c)
            radiance[c] += beta[c] * s[c];

        double mu, sin_theta;
        vs_hg_sample_d(ctx->medium.g, rng_next(rng), &mu, &sin_theta);
        phase_pdf = vs_hg_eval_d(ctx->medium.g, 1.0 - mu);
        scatter_dir(w, mu, sin_theta, rng_next(rng));
        vdbs_volume_index_vector(ctx->volume, w, d);
        if (bounce >= ctx->max_bounces) {
            /* No further scattering: the sky through the remaining transmittance. */
            if (ctx->lights.has_sky) {
                double tr_env = ratio_track(tr, rng, xi, d, HUGE_VAL);
                double L[3], weight = escape_weight(ctx, w, phase_pdf) * tr_env;
                sky_radiance(ctx, w, 1, L);
                for (int c = 0; c < 3; ++c)
                    radiance[c] += beta[c] * L[c] * weight;
            }
            return;
        }
        if (bounce >= REF_RR_START && bmax < 1.0) {
            if (rng_next(rng) >= bmax)
                return;
            for (int c = 0; c < 3; ++c)
                beta[c] /= bmax;
        }
    }
}

/* ---- rendering ---- */

/* One pixel's round of round_spp samples after n_old earlier ones: Welford's running mean
 * and sum of squared deviations, merged with the earlier rounds' sums in acc (NULL: one
 * round only), written to the image as rgb and se. */
static void render_pixel(const ref_ctx *ctx, ref_tracker *tr, const vdbs_camera_frame *frame,
                         uint64_t seed, int64_t p, int64_t n_old, int round_spp, double *acc,
                         vdbs_image *image)
{
    const uint64_t first_sample = (uint64_t)n_old;
    int px = (int)(p % frame->width), py = (int)(p / frame->width);
    double dir[3];
    vdbs_camera_ray(frame, px + 0.5, py + 0.5, dir);
    /* Welford's running mean and sum of squared deviations. */
    double mean[3] = {0.0, 0.0, 0.0}, m2[3] = {0.0, 0.0, 0.0};
    for (int s = 0; s < round_spp; ++s) {
        ref_rng rng = rng_make(seed, (uint64_t)p, first_sample + (uint64_t)s);
        double l[3];
        trace_camera(ctx, tr, &rng, frame->origin, dir, l);
        for (int c = 0; c < 3; ++c) {
            double delta = l[c] - mean[c];
            mean[c] += delta / (s + 1);
            m2[c] += delta * (l[c] - mean[c]);
        }
    }
    float *rgb = image->rgb + 3 * p;
    float *se = image->se ? image->se + 3 * p : NULL;
    for (int c = 0; c < 3; ++c) {
        double n = (double)round_spp;
        double m = mean[c], q = m2[c];
        if (acc) {
            double *a = acc + 6 * p + 2 * c;
            if (n_old > 0) {
                /* Merge with the earlier rounds (Chan et al.). */
                double na = (double)n_old, delta = m - a[0];
                n = na + round_spp;
                m = a[0] + delta * round_spp / n;
                q = a[1] + q + delta * delta * na * round_spp / n;
            }
            a[0] = m;
            a[1] = q;
        }
        rgb[c] = (float)m;
        if (se)
            se[c] = n > 1.0 ? (float)sqrt(fmax(q, 0.0) / (n * (n - 1.0))) : 0.0f;
    }
}

/* One round over all pixels; *done counts the finished pixels for the progress of a render
 * without a time limit. */
static void render_round(const ref_ctx *ctx, const vdbs_camera_frame *frame,
                         const vdbs_reference_options *options, int64_t n_old, int round_spp,
                         double *acc, vdbs_image *image, int64_t *done)
{
    const int64_t pixels = (int64_t)frame->width * frame->height;
    vdbs_progress *progress = options->progress;
#pragma omp parallel
    {
        ref_tracker tr;
        tracker_init(ctx, &tr);
#pragma omp for schedule(dynamic, 4)
        for (int64_t p = 0; p < pixels; ++p) {
            if (vdbs_progress_cancelled(progress))
                continue; /* an OpenMP loop cannot break */
            render_pixel(ctx, &tr, frame, options->seed, p, n_old, round_spp, acc, image);
            if (progress && options->time_limit <= 0.0 && options->tolerance <= 0.0) {
                int64_t now_done;
#pragma omp atomic capture
                now_done = ++*done;
                if (omp_get_thread_num() == 0)
                    vdbs_progress_update(progress,
                                         (uint64_t)((double)progress->total * now_done / pixels));
            }
        }
    }
}

/* Under a time limit, after a round of round_spp samples that began at round_started (the
 * render at started; taken samples per pixel so far): the next round's samples per pixel,
 * 0 when none fits in the time left. */
static int next_round(const vdbs_reference_options *options, double started, double round_started,
                      int round_spp, int64_t taken)
{
    vdbs_progress *progress = options->progress;
    double now = vdbs_now(), elapsed = now - started, last = now - round_started;
    if (progress)
        vdbs_progress_update(progress, (uint64_t)((double)progress->total *
                                                  fmin(1.0, elapsed / options->time_limit)));
    /* Rounds double while they are short (each costs a fork and a join of the
     * threads, which a busy machine can stretch to milliseconds), and the next round
     * must fit in the time left. */
    int64_t next = round_spp;
    if (last < options->time_limit / 50.0)
        next *= 2;
    while (next > options->spp && elapsed + last * next / round_spp > options->time_limit)
        next /= 2;
    if (elapsed + last * next / round_spp > options->time_limit || taken + next > INT_MAX)
        return 0;
    return (int)next;
}

/* With a tolerance, after `taken` samples per pixel: 0 once the image's noise is within it,
 * else the next round's samples per pixel, what the noise so far says the tolerance needs
 * (noise falls as 1 / sqrt(samples)), at most 4 times those taken: the first rounds' noise is
 * itself a rough estimate. */
static int tolerance_round(const vdbs_reference_options *options, const vdbs_image *image,
                           int64_t taken)
{
    const double noise = vdbs_image_noise(image);
    if (!(noise > options->tolerance))
        return 0;
    const double ratio = noise / options->tolerance;
    if (options->progress)
        vdbs_progress_update(options->progress,
                             (uint64_t)((double)options->progress->total / (ratio * ratio)));
    double need = ceil((double)taken * (ratio * ratio - 1.0));
    need = fmin(fmax(need, (double)options->spp), 4.0 * (double)taken);
    return taken + need > INT_MAX ? 0 : (int)need;
}

vdbs_status vdbs_reference_render(const vdbs_volume *volume, const vdbs_scene *scene,
                                  const vdbs_camera_frame *frame,
                                  const vdbs_reference_options *options, vdbs_image *image,
                                  int *spp_done, vdbs_error *err)
{
    if (spp_done)
        *spp_done = 0;
    if (options->spp < 1)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "reference: spp must be >= 1 (got %d)",
                              options->spp);
    vdbs_status st = render_check_image(frame, image, RENDER_IMAGE_REFERENCE, err);
    if (st != VDBS_OK)
        return st;
    ref_ctx ctx;
    st = ctx_init(volume, scene, options->max_bounces, !options->no_env_nee, &ctx, err);
    if (st != VDBS_OK)
        return st;

    const int64_t pixels = (int64_t)frame->width * frame->height;
    const double started = vdbs_now();
    int64_t done = 0;
    int64_t taken = 0; /* samples per pixel finished */
    int round_spp = options->spp;
    /* Rounds under a time limit keep each pixel's mean and sum of squared deviations in
     * double (the float image would round them between rounds). */
    double *acc = NULL;
    if (options->time_limit > 0.0 || options->tolerance > 0.0) {
        acc = malloc(sizeof *acc * 6 * (size_t)pixels);
        if (!acc) {
            ctx_free(&ctx);
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the pixel sums");
        }
    }
    for (;;) {
        const double round_started = vdbs_now();
        render_round(&ctx, frame, options, taken, round_spp, acc, image, &done);
        if (vdbs_progress_cancelled(options->progress)) {
            free(acc);
            ctx_free(&ctx);
            return vdbs_error_cancelled(err);
        }
        taken += round_spp;
        if (options->tolerance > 0.0) {
            int next = tolerance_round(options, image, taken);
            if (next > 0 && options->time_limit > 0.0) {
                /* As many of those as fit in the time left at the last round's pace. */
                const double now = vdbs_now(), per_spp = (now - round_started) / round_spp;
                const double fits = floor((options->time_limit - (now - started)) / per_spp);
                next = fits < 1.0 ? 0 : (int)fmin((double)next, fits);
            }
            if (next == 0)
                break;
            round_spp = next;
            continue;
        }
        if (!(options->time_limit > 0.0))
            break;
        round_spp = next_round(options, started, round_started, round_spp, taken);
        if (round_spp == 0)
            break;
    }
    if (spp_done)
        *spp_done = (int)taken;
    free(acc);
    ctx_free(&ctx);
    return VDBS_OK;
}

/* ---- energy tally ---- */

typedef struct tally_sums {
    double r, r2, t, t2, a, a2, side;
} tally_sums;

/* Where the tally's paths start: on a disc of `radius` about `centre` facing the sun
 * (unit travel s, disc axes u1 and u2), `back` behind it so that every start lies outside
 * the support box; sun_axis is the index axis whose faces face the sun most nearly. */
typedef struct tally_setup {
    const double *centre;
    double radius, back;
    double s[3], u1[3], u2[3];
    double sun_index[3]; /* s in index space */
    int sun_axis;
    int max_bounces;
    uint64_t seed;
} tally_setup;

/* Index axis whose faces are the most nearly perpendicular to the unit travel s: the
 * world-space normal of face a is the gradient of index coordinate a. */
static int sun_face_axis(const vdbs_volume *volume, const double s[3])
{
    int sun_axis = 0;
    double best = -1.0;
    for (int a = 0; a < 3; ++a) {
        const double *n = volume->world_to_index[a];
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double c = fabs(n[0] * s[0] + n[1] * s[1] + n[2] * s[2]) / len;
        if (c > best) {
            best = c;
            sun_axis = a;
        }
    }
    return sun_axis;
}

static void tally_setup_init(const ref_ctx *ctx, const vdbs_light *sun, const double centre[3],
                             double radius, int max_bounces, uint64_t seed, tally_setup *ts)
{
    ts->centre = centre;
    ts->radius = radius;
    ts->max_bounces = max_bounces;
    ts->seed = seed;
    memcpy(ts->s, sun->direction, sizeof ts->s);
    normalize3(ts->s);
    ts->sun_axis = sun_face_axis(ctx->volume, ts->s);
    /* Start far enough back along the sun that every start is outside the support box. */
    double box_centre[3], box_radius;
    support_sphere(ctx, box_centre, &box_radius);
    double dc = 0.0;
    for (int a = 0; a < 3; ++a)
        dc += (centre[a] - box_centre[a]) * (centre[a] - box_centre[a]);
    ts->back = sqrt(dc) + box_radius + radius + 1.0;
    vdbs_ortho_basis(ts->s, ts->u1, ts->u2);
    vdbs_volume_index_vector(ctx->volume, ts->s, ts->sun_index);
}

/* Path n of the tally: analog tracking with the albedo as survival weight; adds the energy
 * it reflects, transmits (and leaks through the side faces) and absorbs to acc. */
static void tally_path(const ref_ctx *ctx, ref_tracker *tr, const tally_setup *ts, int64_t n,
                       tally_sums *acc)
{
    const double *centre = ts->centre, *s = ts->s, *u1 = ts->u1, *u2 = ts->u2;
    const double albedo = ctx->medium.albedo[0];
    ref_rng rng = rng_make(ts->seed, UINT64_C(0x7a11), (uint64_t)n);
    double rr = ts->radius * sqrt(rng_next(&rng)), phi = 2.0 * VDBS_PI * rng_next(&rng);
    double xw[3], xi[3], w[3], d[3];
    for (int a = 0; a < 3; ++a)
        xw[a] = centre[a] + rr * (cos(phi) * u1[a] + sin(phi) * u2[a]) - ts->back * s[a];
    memcpy(w, s, sizeof w);
    memcpy(d, ts->sun_index, sizeof d);
    vdbs_volume_index_point(ctx->volume, xw, xi);
    tr->budget = REF_PATH_STEPS;
    double beta = 1.0, refl = 0.0, trans = 0.0, absorbed = 0.0;
    for (int bounce = 1;; ++bounce) {
        double t;
        int axis;
        int r = delta_track(tr, &rng, xi, d, HUGE_VAL, &t, &axis);
        if (r == TRACK_ESCAPED) {
            if (w[0] * s[0] + w[1] * s[1] + w[2] * s[2] < 0.0)
                refl = beta;
            else
                trans = beta;
            if (axis >= 0 && axis != ts->sun_axis)
                acc->side += beta;
            break;
        }
        if (r == TRACK_GAVE_UP || bounce > ts->max_bounces) {
            absorbed += beta;
            break;
        }
        for (int a = 0; a < 3; ++a) {
            xw[a] += w[a] * t;
            xi[a] += d[a] * t;
        }
        absorbed += beta * (1.0 - albedo);
        beta *= albedo;
        if (!(beta > 0.0))
            break;
        double mu, sin_theta;
        vs_hg_sample_d(ctx->medium.g, rng_next(&rng), &mu, &sin_theta);
        scatter_dir(w, mu, sin_theta, rng_next(&rng));
        vdbs_volume_index_vector(ctx->volume, w, d);
        if (bounce >= REF_RR_START && beta < 1.0) {
            if (rng_next(&rng) >= beta)
                break;
            beta = 1.0;
        }
    }
    acc->r += refl;
    acc->r2 += refl * refl;
    acc->t += trans;
    acc->t2 += trans * trans;
    acc->a += absorbed;
    acc->a2 += absorbed * absorbed;
}

/* The chunks' sums in chunk order (whatever the threads did), as means and their
 * standard errors over `paths` paths. */
static void tally_finish(const tally_sums *sums, int64_t chunks, int64_t paths,
                         vdbs_reference_tally *tally)
{
    tally_sums total = {0};
    for (int64_t k = 0; k < chunks; ++k) {
        total.r += sums[k].r;
        total.r2 += sums[k].r2;
        total.t += sums[k].t;
        total.t2 += sums[k].t2;
        total.a += sums[k].a;
        total.a2 += sums[k].a2;
        total.side += sums[k].side;
    }
    const double n = (double)paths;
    tally->reflected = total.r / n;
    tally->transmitted = total.t / n;
    tally->absorbed = total.a / n;
    tally->side_leak = total.side / n;
    if (paths > 1) {
        tally->reflected_se =
            sqrt(fmax(0.0, total.r2 / n - tally->reflected * tally->reflected) / (n - 1.0));
        tally->transmitted_se =
            sqrt(fmax(0.0, total.t2 / n - tally->transmitted * tally->transmitted) / (n - 1.0));
        tally->absorbed_se =
            sqrt(fmax(0.0, total.a2 / n - tally->absorbed * tally->absorbed) / (n - 1.0));
    }
}

vdbs_status vdbs_reference_tally_sun(const vdbs_volume *volume, const vdbs_scene *scene,
                                     const double centre[3], double radius, int64_t paths,
                                     int max_bounces, uint64_t seed, vdbs_reference_tally *tally,
                                     vdbs_error *err)
{
    memset(tally, 0, sizeof *tally);
    if (paths < 1 || !(radius >= 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "tally: need paths >= 1 and radius >= 0");
    const vdbs_light *sun = NULL;
    for (int i = 0; i < scene->light_count && !sun; ++i)
        if (scene->lights[i].type == VDBS_LIGHT_SUN)
            sun = &scene->lights[i];
    if (!sun)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "tally: the scene has no sun");
    ref_ctx ctx;
    vdbs_status st = ctx_init(volume, scene, max_bounces, 1, &ctx, err);
    if (st != VDBS_OK)
        return st;
    tally_setup ts;
    tally_setup_init(&ctx, sun, centre, radius, max_bounces, seed, &ts);

    const int64_t chunks = (paths + REF_TALLY_CHUNK - 1) / REF_TALLY_CHUNK;
    tally_sums *sums = calloc((size_t)chunks, sizeof *sums);
    if (!sums) {
        ctx_free(&ctx);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the tally");
    }
#pragma omp parallel
    {
        ref_tracker tr;
        tracker_init(&ctx, &tr);
#pragma omp for schedule(dynamic, 1)
        for (int64_t k = 0; k < chunks; ++k) {
            tally_sums acc = {0};
            int64_t end = (k + 1) * REF_TALLY_CHUNK < paths ? (k + 1) * REF_TALLY_CHUNK : paths;
            for (int64_t n = k * REF_TALLY_CHUNK; n < end; ++n)
                tally_path(&ctx, &tr, &ts, n, &acc);
            sums[k] = acc;
        }
    }
    tally_finish(sums, chunks, paths, tally);
    free(sums);
    ctx_free(&ctx);
    return VDBS_OK;
}

/* ---- probe: light tracing with a track-length tally of the scattered light ---- */

/* Photons per batch of the probe (batches fix the merge order and give the errors). */
#define PROBE_BATCH 4096
/* The probe asks for at least this many batches (when it has that many photons). */
#define PROBE_MIN_BATCHES 64
/* Cells of the grid that finds the balls a flight crosses. */
#define PROBE_GRID_MAX_CELLS (1 << 22)
#define PROBE_GRID_MAX_DIM 1024

enum { PROBE_SUN, PROBE_POINT, PROBE_SKY, PROBE_ENV };

/* A point's sums: the fluence per channel, the flux's x, y, z components per channel, the
 * second moment's xx, yy, zz, xy, xz, yz components per channel. */
#define PROBE_PHI 0
#define PROBE_FLUX 3
#define PROBE_T2 12
#define PROBE_WORDS 30

typedef struct probe_source {
    int kind;
    const vdbs_direct_light *light; /* suns and points */
    double power[3];                /* RGB power (W) */
    double cdf;                     /* selection CDF up to and including this source */
} probe_source;

/* The balls binned into a uniform world-space grid of cubic cells of side h: cell c holds
 * items[start[c] .. start[c + 1]), every ball whose bounding box meets the cell. */
typedef struct probe_grid {
    double lo[3], h;
    int dims[3];
    size_t *start;
    size_t *items;
} probe_grid;

typedef struct probe_ctx {
    const ref_ctx *ref;
    const double *points;
    size_t count;
    double radius, radius2;
    probe_grid grid;
    probe_source sources[VDBS_MAX_LIGHTS + 2];
    int source_count;
    double centre[3], disc_radius; /* the support box's bounding sphere */
    double disc_area;              /* pi disc_radius^2 */
} probe_ctx;

/* One thread's sums for the batch it works on. */
typedef struct probe_thread {
    double *acc;          /* PROBE_WORDS per point */
    uint64_t *batch_mark; /* batch index + 1 that last touched the point */
    uint64_t *seg_mark;   /* flight number that last visited the point */
    size_t *touched;      /* points touched in this batch */
    size_t touched_count;
    uint64_t batch, seg;
} probe_thread;

/* A finished batch's sums over the points it touched, waiting for its turn to merge. */
typedef struct probe_result {
    size_t n;       /* points touched */
    double photons; /* in the batch */
    size_t *idx;    /* n points */
    double *val;    /* PROBE_WORDS n sums, as probe_thread.acc */
} probe_result;

/* Moves the thread's sums for its batch into a new result (NULL when out of memory: the
 * sums are dropped) and clears them. */
static probe_result *probe_pack(probe_thread *th, double photons)
{
    size_t n = th->touched_count;
    probe_result *r = malloc(sizeof *r + n * (sizeof *r->idx + PROBE_WORDS * sizeof *r->val));
    if (r) {
        r->n = n;
        r->photons = photons;
        r->val = (double *)(r + 1);
        r->idx = (size_t *)(r->val + PROBE_WORDS * n);
    }
    for (size_t j = 0; j < n; ++j) {
        size_t i = th->touched[j];
        if (r) {
            r->idx[j] = i;
            memcpy(r->val + PROBE_WORDS * j, th->acc + PROBE_WORDS * i,
                   PROBE_WORDS * sizeof *r->val);
        }
        memset(th->acc + PROBE_WORDS * i, 0, PROBE_WORDS * sizeof *th->acc);
    }
    th->touched_count = 0;
    return r;
}

static void probe_grid_free(probe_grid *g)
{
    free(g->start);
    free(g->items);
    memset(g, 0, sizeof *g);
}

static vdbs_status probe_grid_build(probe_grid *g, const double *p, size_t n, double r,
                                    vdbs_error *err)
{
    memset(g, 0, sizeof *g);
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = HUGE_VAL;
        hi[a] = -HUGE_VAL;
    }
    for (size_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            lo[a] = fmin(lo[a], p[3 * i + a] - r);
            hi[a] = fmax(hi[a], p[3 * i + a] + r);
        }
    double ext[3], vol = 1.0, big = 0.0;
    for (int a = 0; a < 3; ++a) {
        /* A margin keeps balls on the box's faces inside it after rounding. */
        double m = 1e-9 * (hi[a] - lo[a]) + 1e-300;
        lo[a] -= m;
        hi[a] += m;
        ext[a] = hi[a] - lo[a];
        vol *= ext[a];
        big = fmax(big, ext[a]);
    }
    /* About one ball per cell, and cells no smaller than a ball (at most 8 cells a ball). */
    double h = fmax(2.0 * r, cbrt(vol / (double)n));
    if (!(h > 0.0))
        h = big > 0.0 ? big : 1.0;
    for (;;) {
        double cells = 1.0;
        int fits = 1;
        for (int a = 0; a < 3; ++a) {
            double d = fmax(1.0, ceil(ext[a] / h));
            fits &= d <= PROBE_GRID_MAX_DIM;
            cells *= d;
            g->dims[a] = (int)fmin(d, PROBE_GRID_MAX_DIM + 1.0);
        }
        if (fits && cells <= PROBE_GRID_MAX_CELLS)
            break;
        h *= 1.25;
    }
    g->h = h;
    memcpy(g->lo, lo, sizeof lo);
    const size_t cells = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    g->start = calloc(cells + 1, sizeof *g->start);
    if (!g->start)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the probe grid");
    for (int pass = 0; pass < 2; ++pass) {
        for (size_t i = 0; i < n; ++i) {
            int c0[3], c1[3];
            for (int a = 0; a < 3; ++a) {
                double x = p[3 * i + a] - g->lo[a];
                c0[a] = (int)fmax(0.0, floor((x - r) / h));
                c1[a] = (int)fmin(g->dims[a] - 1.0, floor((x + r) / h));
            }
            for (int z = c0[2]; z <= c1[2]; ++z)
                for (int y = c0[1]; y <= c1[1]; ++y)
                    for (int x = c0[0]; x <= c1[0]; ++x) {
                        size_t c = (size_t)x + (size_t)g->dims[0] * (y + (size_t)g->dims[1] * z);
                        if (pass == 0)
                            ++g->start[c + 1];
                        else
                            g->items[g->start[c]++] = i;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < cells; ++c)
                g->start[c + 1] += g->start[c];
            g->items = malloc(sizeof *g->items * (g->start[cells] > 0 ? g->start[cells] : 1));
            if (!g->items) {
                probe_grid_free(g);
                return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the probe grid");
            }
        } else {
            /* The fill advanced each start to the next cell's: shift them back. */
            for (size_t c = cells; c > 0; --c)
                g->start[c] = g->start[c - 1];
            g->start[0] = 0;
        }
    }
    return VDBS_OK;
}

/* Adds the flight o + t w (world, w unit), t in [0, tmax], carrying the RGB weight f, to
 * every ball it crosses: chord x f to the fluence sums, chord x f x w to the flux sums. */
static void probe_flight(const probe_ctx *pc, probe_thread *th, const double o[3],
                         const double w[3], double tmax, const double f[3])
{
    const probe_grid *g = &pc->grid;
    double t0 = 0.0, t1 = tmax;
    for (int a = 0; a < 3; ++a) {
        double lo = g->lo[a], hi = g->lo[a] + g->h * g->dims[a];
        if (w[a] != 0.0) {
            double ta = (lo - o[a]) / w[a], tb = (hi - o[a]) / w[a];
            t0 = fmax(t0, fmin(ta, tb));
            t1 = fmin(t1, fmax(ta, tb));
        } else if (o[a] < lo || o[a] > hi) {
            return;
        }
    }
    if (!(t0 <= t1))
        return;
    const uint64_t seg = ++th->seg;
    int c[3], step[3];
    double next[3], delta[3];
    for (int a = 0; a < 3; ++a) {
        double x = (o[a] + w[a] * t0 - g->lo[a]) / g->h;
        c[a] = (int)fmin(fmax(floor(x), 0.0), g->dims[a] - 1.0);
        if (w[a] > 0.0) {
            step[a] = 1;
            next[a] = (g->lo[a] + (c[a] + 1) * g->h - o[a]) / w[a];
            delta[a] = g->h / w[a];
        } else if (w[a] < 0.0) {
            step[a] = -1;
            next[a] = (g->lo[a] + c[a] * g->h - o[a]) / w[a];
            delta[a] = -g->h / w[a];
        } else {
            step[a] = 0;
            next[a] = delta[a] = HUGE_VAL;
        }
    }
    for (;;) {
        size_t cell = (size_t)c[0] + (size_t)g->dims[0] * (c[1] + (size_t)g->dims[1] * c[2]);
        for (size_t k = g->start[cell]; k < g->start[cell + 1]; ++k) {
            size_t i = g->items[k];
            if (th->seg_mark[i] == seg)
                continue;
            th->seg_mark[i] = seg;
            const double *p = pc->points + 3 * i;
            double v[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
            double b = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
            double q[3] = {v[0] - b * w[0], v[1] - b * w[1], v[2] - b * w[2]};
            double h2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            if (!(h2 < pc->radius2))
                continue;
            double s = sqrt(pc->radius2 - h2);
            double len = fmin(tmax, b + s) - fmax(0.0, b - s);
            if (!(len > 0.0))
                continue;
            if (th->batch_mark[i] != th->batch + 1) {
                th->batch_mark[i] = th->batch + 1;
                th->touched[th->touched_count++] = i;
            }
            double *acc = th->acc + PROBE_WORDS * i;
            const double ww[6] = {w[0] * w[0], w[1] * w[1], w[2] * w[2],
                                  w[0] * w[1], w[0] * w[2], w[1] * w[2]};
            for (int ch = 0; ch < 3; ++ch) {
                double x = f[ch] * len;
                acc[PROBE_PHI + ch] += x;
                for (int a = 0; a < 3; ++a)
                    acc[PROBE_FLUX + 3 * a + ch] += x * w[a];
                for (int k = 0; k < 6; ++k)
                    acc[PROBE_T2 + 3 * k + ch] += x * ww[k];
            }
        }
        int a = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
        if (next[a] > t1)
            break;
        c[a] += step[a];
        if (c[a] < 0 || c[a] >= g->dims[a])
            break;
        next[a] += delta[a];
    }
}

/* A direction uniform over the sphere. */
static void uniform_dir(ref_rng *rng, double w[3])
{
    double z = 1.0 - 2.0 * rng_next(rng), phi = 2.0 * VDBS_PI * rng_next(rng);
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    w[0] = r * cos(phi);
    w[1] = r * sin(phi);
    w[2] = z;
}

/* One photon: emission, then tracking with the tally of every flight after a scattering. */
static void probe_photon(const probe_ctx *pc, ref_tracker *tr, ref_rng *rng, probe_thread *th)
{
    const ref_ctx *ctx = pc->ref;
    /* Sources are chosen in proportion to their power; a photon carries power / choice. */
    double u = rng_next(rng);
    int k = 0;
    while (k < pc->source_count - 1 && !(u < pc->sources[k].cdf))
        ++k;
    const probe_source *src = &pc->sources[k];
    const double select = src->cdf - (k > 0 ? pc->sources[k - 1].cdf : 0.0);
    double power[3], xw[3], w[3];
    for (int c = 0; c < 3; ++c)
        power[c] = src->power[c] / select;
    if (src->kind == PROBE_POINT) {
        memcpy(xw, src->light->world, sizeof xw);
        uniform_dir(rng, w);
    } else {
        if (src->kind == PROBE_SUN) {
            memcpy(w, src->light->world, sizeof w);
        } else if (src->kind == PROBE_SKY) {
            uniform_dir(rng, w);
        } else {
            double from[3], radiance[3];
            double pdf =
                vdbs_envmap_sampler_draw(&ctx->env, rng_next(rng), rng_next(rng), from, radiance);
            if (!(pdf > 0.0))
                return;
            for (int a = 0; a < 3; ++a)
                w[a] = -from[a];
            normalize3(w);
            /* The map's power through the disc, sampled by its luminance. */
            for (int c = 0; c < 3; ++c)
                power[c] = radiance[c] / pdf * pc->disc_area / select;
        }
        double t1[3], t2[3];
        vdbs_ortho_basis(w, t1, t2);
        double rr = pc->disc_radius * sqrt(rng_next(rng)), phi = 2.0 * VDBS_PI * rng_next(rng);
        double c1 = rr * cos(phi), c2 = rr * sin(phi);
        for (int a = 0; a < 3; ++a)
            xw[a] = pc->centre[a] + c1 * t1[a] + c2 * t2[a] - 2.0 * pc->disc_radius * w[a];
    }
    double xi[3], d[3];
    vdbs_volume_index_point(ctx->volume, xw, xi);
    vdbs_volume_index_vector(ctx->volume, w, d);
    double beta[3] = {1.0, 1.0, 1.0};
    tr->budget = REF_PATH_STEPS;
    for (int bounce = 0;; ++bounce) {
        double t;
        int axis;
        int r = delta_track(tr, rng, xi, d, HUGE_VAL, &t, &axis);
        if (r == TRACK_GAVE_UP)
            return;
        if (bounce > 0) {
            double f[3] = {power[0] * beta[0], power[1] * beta[1], power[2] * beta[2]};
            probe_flight(pc, th, xw, w, r == TRACK_ESCAPED ? HUGE_VAL : t, f);
        }
        if (r == TRACK_ESCAPED || bounce >= ctx->max_bounces)
            return;
        for (int a = 0; a < 3; ++a) {
            xw[a] += w[a] * t;
            xi[a] += d[a] * t;
        }
        if (bounce == 0 && src->kind == PROBE_POINT && t < ctx->lights.min_distance) {
            double s = t / ctx->lights.min_distance;
            for (int c = 0; c < 3; ++c)
                beta[c] *= s * s;
        }
        for (int c = 0; c < 3; ++c)
            beta[c] *= ctx->medium.albedo[c];
        double bmax = fmax(beta[0], fmax(beta[1], beta[2]));
        if (!(bmax > 0.0))
            return;
        double mu, sin_theta;
        vs_hg_sample_d(ctx->medium.g, rng_next(rng), &mu, &sin_theta);
        scatter_dir(w, mu, sin_theta, rng_next(rng));
        vdbs_volume_index_vector(ctx->volume, w, d);
        if (bounce + 1 >= REF_RR_START && bmax < 1.0) {
            if (rng_next(rng) >= bmax)
                return;
            for (int c = 0; c < 3; ++c)
                beta[c] /= bmax;
        }
    }
}

static double mean3(const double v[3])
{
    return (v[0] + v[1] + v[2]) / 3.0;
}

/* The lights as photon sources (those with power), with their selection CDF; returns the
 * total power's mean channel (0: nothing to trace). An env map's power is its integral
 * over the sphere times the disc's area. */
static double probe_sources(probe_ctx *pc)
{
    const ref_ctx *ctx = pc->ref;
    const double disc = pc->disc_area;
    probe_source cand[VDBS_MAX_LIGHTS + 2];
    int n = 0;
    memset(cand, 0, sizeof cand);
    for (int i = 0; i < ctx->lights.direct_count && n < VDBS_MAX_LIGHTS; ++i) {
        const vdbs_direct_light *l = &ctx->lights.direct[i];
        probe_source *s = &cand[n++];
        s->light = l;
        s->kind = l->type == VDBS_LIGHT_SUN ? PROBE_SUN : PROBE_POINT;
        for (int c = 0; c < 3; ++c)
            s->power[c] = l->color[c] * (s->kind == PROBE_SUN ? disc : 4.0 * VDBS_PI);
    }
    if (ctx->lights.has_sky) {
        probe_source *s = &cand[n++];
        s->kind = PROBE_SKY;
        for (int c = 0; c < 3; ++c)
            s->power[c] = 4.0 * VDBS_PI * ctx->lights.sky[c] * disc;
    }
    if (ctx->lights.env && ctx->env.total > 0.0) {
        const vdbs_envmap *map = ctx->lights.env;
        probe_source *s = &cand[n++];
        s->kind = PROBE_ENV;
        for (int y = 0; y < map->height; ++y)
            for (int x = 0; x < map->width; ++x) {
                double omega = vdbs_envmap_texel_solid_angle(map, x, y);
                const float *t = map->rgb + 3 * ((size_t)y * map->width + x);
                for (int c = 0; c < 3; ++c)
                    s->power[c] += t[c] * omega * disc;
            }
    }
    double total = 0.0;
    pc->source_count = 0;
    for (int k = 0; k < n; ++k)
        if (mean3(cand[k].power) > 0.0) {
            total += mean3(cand[k].power);
            pc->sources[pc->source_count] = cand[k];
            pc->sources[pc->source_count++].cdf = total;
        }
    for (int k = 0; k < pc->source_count; ++k)
        pc->sources[k].cdf /= total;
    if (pc->source_count > 0)
        pc->sources[pc->source_count - 1].cdf = 1.0;
    return total;
}

static vdbs_status probe_check(const vdbs_reference_probe_options *o, const double *points,
                               size_t count, vdbs_error *err)
{
    if (o->photons < 0 || o->max_bounces < 0 || !(o->radius >= 0.0) || !isfinite(o->radius))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "probe: photons (%lld), radius (%g) and max_bounces (%d) must be "
                              ">= 0 and finite (0: default)",
                              (long long)o->photons, o->radius, o->max_bounces);
    if (count > 0 && !points)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "probe: %zu points but no coordinates", count);
    for (size_t i = 0; i < 3 * count; ++i)
        if (!isfinite(points[i]))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "probe: point %zu is not finite", i / 3);
    return VDBS_OK;
}

static void probe_clear(const vdbs_reference_probe_outputs *out, size_t count)
{
    if (out->ms)
        memset(out->ms, 0, sizeof *out->ms * 3 * count);
    if (out->ms_l1)
        memset(out->ms_l1, 0, sizeof *out->ms_l1 * 9 * count);
    if (out->ms_se)
        memset(out->ms_se, 0, sizeof *out->ms_se * 3 * count);
    if (out->ms_l1_se)
        memset(out->ms_l1_se, 0, sizeof *out->ms_l1_se * 9 * count);
    if (out->ms_t2)
        memset(out->ms_t2, 0, sizeof *out->ms_t2 * 18 * count);
    if (out->ms_t2_se)
        memset(out->ms_t2_se, 0, sizeof *out->ms_t2_se * 18 * count);
}

/* The probe's sums: each thread's for its batch, the finished batches waiting for their
 * turn, and the merged sums (PROBE_WORDS per point, as probe_thread.acc): s1 of the batches'
 * sums, s2 of their squares over the batch's photons. */
typedef struct probe_sums {
    int threads;
    probe_thread *th;
    probe_result **pending;
    double *s1, *s2;
} probe_sums;

static void probe_sums_free(probe_sums *ps)
{
    for (int k = 0; ps->th && k < ps->threads; ++k) {
        free(ps->th[k].acc);
        free(ps->th[k].batch_mark);
        free(ps->th[k].seg_mark);
        free(ps->th[k].touched);
    }
    free(ps->th);
    free(ps->pending);
    free(ps->s1);
    free(ps->s2);
    memset(ps, 0, sizeof *ps);
}

/* 0 when out of memory (free with probe_sums_free either way). */
static int probe_sums_alloc(probe_sums *ps, size_t count, int64_t batches)
{
    ps->threads = omp_get_max_threads();
    ps->s1 = calloc(PROBE_WORDS * count, sizeof *ps->s1);
    ps->s2 = calloc(PROBE_WORDS * count, sizeof *ps->s2);
    ps->th = calloc((size_t)ps->threads, sizeof *ps->th);
    ps->pending = calloc((size_t)batches, sizeof *ps->pending);
    int ok = ps->s1 && ps->s2 && ps->th && ps->pending;
    for (int k = 0; ok && k < ps->threads; ++k) {
        probe_thread *th = &ps->th[k];
        th->acc = calloc(PROBE_WORDS * count, sizeof *th->acc);
        th->batch_mark = calloc(count, sizeof *th->batch_mark);
        th->seg_mark = calloc(count, sizeof *th->seg_mark);
        th->touched = malloc(count * sizeof *th->touched);
        ok = th->acc && th->batch_mark && th->seg_mark && th->touched;
    }
    return ok;
}

/* Merges the finished batches whose turn it is (*next onwards, in order); `lost` stands
 * for a batch whose sums could not be kept. */
static void probe_merge_ready(probe_sums *ps, int64_t *next, int64_t batches, probe_result *lost)
{
    while (*next < batches && ps->pending[*next]) {
        probe_result *r = ps->pending[*next];
        for (size_t j = 0; j < r->n; ++j)
            for (int q = 0; q < PROBE_WORDS; ++q) {
                double x = r->val[PROBE_WORDS * j + q];
                ps->s1[PROBE_WORDS * r->idx[j] + q] += x;
                ps->s2[PROBE_WORDS * r->idx[j] + q] += x * x / r->photons;
            }
        if (r != lost)
            free(r);
        ps->pending[(*next)++] = NULL;
    }
}

/* Traces the photons in batches of `batch` on all threads into ps; 0 when a batch's sums
 * could not be kept (out of memory). */
static int probe_trace(const probe_ctx *pc, const vdbs_reference_probe_options *o, int64_t photons,
                       int64_t batch, int64_t batches, probe_sums *ps)
{
    vdbs_progress *progress = o->progress;
    int ok = 1;
    probe_result lost = {0};
    int64_t next = 0; /* the next batch to merge */
#pragma omp parallel
    {
        probe_thread *me = &ps->th[omp_get_thread_num()];
        ref_tracker tr;
        tracker_init(pc->ref, &tr);
#pragma omp for schedule(dynamic, 1)
        for (int64_t k = 0; k < batches; ++k) {
            int64_t first = k * batch, end = first + batch < photons ? first + batch : photons;
            me->batch = (uint64_t)k;
            for (int64_t n = first; n < end; ++n) {
                ref_rng rng = rng_make(o->seed, UINT64_C(0x9b0be), (uint64_t)n);
                probe_photon(pc, &tr, &rng, me);
            }
            probe_result *res = probe_pack(me, (double)(end - first));
            /* Batches merge in their order (a finished batch waits in `pending` for the
             * ones before it, and no thread waits for another), so the sums do not
             * depend on the threads. */
#pragma omp critical(vdbs_probe_merge)
            {
                ps->pending[k] = res ? res : &lost;
                if (!res)
                    ok = 0;
                probe_merge_ready(ps, &next, batches, &lost);
                if (progress)
                    vdbs_progress_update(progress,
                                         (uint64_t)((double)progress->total * next / batches));
            }
        }
    }
    return ok;
}

/* The merged sums of `photons` photons in `batches` batches as Sms, its first moment
 * (medium anisotropy g) and its second moment per point of balls of `radius`, the errors from
 * the batches' spread. */
static void probe_results(const probe_sums *ps, size_t count, int64_t photons, int64_t batches,
                          double radius, double g, const vdbs_reference_probe_outputs *out)
{
    const double n = (double)photons, volume_ball = 4.0 / 3.0 * VDBS_PI * radius * radius * radius;
    const double k_phi = 1.0 / (4.0 * VDBS_PI * volume_ball * n);
    const double k_l1 = 3.0 * g / (4.0 * VDBS_PI * volume_ball * n);
    for (size_t i = 0; i < count; ++i)
        for (int q = 0; q < PROBE_WORDS; ++q) {
            double sum = ps->s1[PROBE_WORDS * i + q];
            double var = batches > 1 ? fmax(0.0, ps->s2[PROBE_WORDS * i + q] - sum * sum / n) /
                                           (double)(batches - 1)
                                     : 0.0;
            /* se of the sum: sqrt(n var). */
            double se = sqrt(n * var);
            /* Which output the word q belongs to, its scale and its place there. */
            double *value = out->ms, *error = out->ms_se, k = k_phi;
            size_t at = 3 * i + (size_t)q;
            if (q >= PROBE_T2) {
                value = out->ms_t2;
                error = out->ms_t2_se;
                at = 18 * i + (size_t)(q - PROBE_T2);
            } else if (q >= PROBE_FLUX) {
                value = out->ms_l1;
                error = out->ms_l1_se;
                k = k_l1;
                at = 9 * i + (size_t)(q - PROBE_FLUX);
            }
            if (value)
                value[at] = sum * k;
            if (error)
                error[at] = se * fabs(k);
        }
}

vdbs_status vdbs_reference_probe(const vdbs_volume *volume, const vdbs_scene *scene,
                                 const vdbs_reference_probe_options *options, const double *points,
                                 size_t count, double *ms, double *ms_l1, double *ms_se,
                                 double *ms_l1_se, vdbs_error *err)
{
    const vdbs_reference_probe_outputs out = {ms, ms_l1, NULL, ms_se, ms_l1_se, NULL};
    return vdbs_reference_probe_moments(volume, scene, options, points, count, &out, err);
}

vdbs_status vdbs_reference_probe_moments(const vdbs_volume *volume, const vdbs_scene *scene,
                                         const vdbs_reference_probe_options *options,
                                         const double *points, size_t count,
                                         const vdbs_reference_probe_outputs *outputs,
                                         vdbs_error *err)
{
    const vdbs_reference_probe_options defaults = {0};
    const vdbs_reference_probe_options *o = options ? options : &defaults;
    vdbs_status st = probe_check(o, points, count, err);
    if (st != VDBS_OK)
        return st;
    const int64_t photons = o->photons > 0 ? o->photons : (int64_t)1 << 20;
    const int max_bounces = o->max_bounces > 0 ? o->max_bounces : 1000;
    const double radius = o->radius > 0.0 ? o->radius : 2.0 * volume->mean_voxel_size;
    const vdbs_reference_probe_outputs none = {0};
    const vdbs_reference_probe_outputs out = outputs ? *outputs : none;
    probe_clear(&out, count);

    ref_ctx ctx;
    st = ctx_init(volume, scene, max_bounces, 1, &ctx, err);
    if (st != VDBS_OK)
        return st;
    probe_ctx pc;
    memset(&pc, 0, sizeof pc);
    pc.ref = &ctx;
    pc.points = points;
    pc.count = count;
    pc.radius = radius;
    pc.radius2 = radius * radius;
    support_sphere(&ctx, pc.centre, &pc.disc_radius);
    pc.disc_area = VDBS_PI * pc.disc_radius * pc.disc_radius;
    if (count == 0 || !(probe_sources(&pc) > 0.0) || !(radius > 0.0)) {
        ctx_free(&ctx);
        return VDBS_OK;
    }
    if ((st = probe_grid_build(&pc.grid, points, count, radius, err)) != VDBS_OK) {
        ctx_free(&ctx);
        return st;
    }

    /* Batches of at most PROBE_BATCH photons, at least PROBE_MIN_BATCHES of them when
     * there are that many photons; fixed by the photon count alone. */
    int64_t batch = photons / PROBE_MIN_BATCHES;
    batch = batch < 1 ? 1 : batch > PROBE_BATCH ? PROBE_BATCH : batch;
    const int64_t batches = (photons + batch - 1) / batch;
    probe_sums ps = {0};
    int ok = probe_sums_alloc(&ps, count, batches);
    if (ok)
        ok = probe_trace(&pc, o, photons, batch, batches, &ps);
    if (ok)
        probe_results(&ps, count, photons, batches, radius, ctx.medium.g, &out);
    probe_sums_free(&ps);
    probe_grid_free(&pc.grid);
    ctx_free(&ctx);
    if (!ok)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the probe's sums");
    return VDBS_OK;
}
