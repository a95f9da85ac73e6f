#include "vdbscatter/inet_network.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

#define INET_WINDOW_MAX 4096
/* Buckets at most this long are sorted by insertion, longer ones by qsort. */
#define INET_INSERTION_MAX 32

/* splitmix64's finaliser: a bijection of 64-bit words, so that distinct counters give
 * distinct, well-mixed words. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1) keyed by (seed, particle, stream): a counter-based stream, so that every
 * particle is the same whichever thread draws it and in whatever order. Streams 0 (the CDF
 * offset) and 1..3 (the jitter along each index axis). */
static double hashed_uniform(uint64_t seed, int64_t particle, int stream)
{
    const uint64_t h = mix64(mix64(seed) + 4 * (uint64_t)particle + (uint64_t)stream);
    return (double)(h >> 11) * (1.0 / 9007199254740992.0);
}

/* A bound in doubles to the window's range: a huge or non-finite one clamps, never overflows. */
static int window_clamp(double m)
{
    if (!(m >= 1.0))
        return 1;
    if (m >= INET_WINDOW_MAX)
        return INET_WINDOW_MAX;
    return (int)m;
}

int vdbs_inet_paper_window(int directions, double radius, double mean_sigma_t)
{
    return window_clamp(floor(sqrt((double)directions) * radius * mean_sigma_t / sqrt(VDBS_PI)));
}

int vdbs_inet_window_rule(int64_t particles)
{
    return window_clamp(floor(sqrt((double)particles / 4.0)));
}

void vdbs_inet_basis(const double w[3], double u[3], double v[3])
{
    vdbs_ortho_basis(w, u, v);
}

void vdbs_inet_network_free(vdbs_inet_network *net)
{
    if (!net)
        return;
    free(net->position);
    free(net->voxel);
    free(net->voxel_sigma_t);
    free(net->upstream);
    memset(net, 0, sizeof *net);
}

/* The integral over voxel c's cube of the trilinear density between the voxel centres, over
 * the cube's volume: per axis the centre weighs 3/4 and each face neighbour 1/8 (the hat
 * function's integral over the cube). Negative densities count as none. */
static double cube_density(pnanovdb_buf_t buf, pnanovdb_readaccessor_t *acc, const int32_t c[3])
{
    static const double weight[3] = {0.125, 0.75, 0.125};
    double sum = 0.0;
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const double rho =
                    (double)vs_density_voxel(buf, acc, vs_coord(c[0] + dx, c[1] + dy, c[2] + dz));
                if (rho > 0.0)
                    sum += weight[dx + 1] * weight[dy + 1] * weight[dz + 1] * rho;
            }
    return sum;
}

/* Every output voxel's cube mean sigma_t (into sigma_t) and optical mass as prefix sums
 * (count + 1 entries, prefix[0] = 0), and the mean sigma_t at the centres of the voxels that
 * hold any (for the paper's window bound). */
static vdbs_status voxel_masses(const vdbs_volume *volume, double density_scale, double **prefix,
                                float *sigma_t, double *mean_sigma_t, vdbs_error *err)
{
    const size_t count = volume->coord_count;
    double *sum = malloc(sizeof *sum * (count + 1));
    if (!sum)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the masses of %zu voxels",
                              count);
    const double voxel_volume = vdbs_volume_voxel_volume(volume);
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
#pragma omp parallel
    {
        pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
#pragma omp for schedule(static)
        for (size_t n = 0; n < count; ++n)
            sigma_t[n] = (float)(density_scale * cube_density(buf, &acc, volume->coords + 3 * n));
    }
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    double sigma_sum = 0.0;
    size_t active = 0;
    sum[0] = 0.0;
    for (size_t n = 0; n < count; ++n) {
        const int32_t *c = volume->coords + 3 * n;
        const double centre =
            density_scale * (double)vs_density_voxel(buf, &acc, vs_coord(c[0], c[1], c[2]));
        if (centre > 0.0) {
            sigma_sum += centre;
            ++active;
        }
        sum[n + 1] = sum[n] + (double)sigma_t[n] * voxel_volume;
    }
    const double total = sum[count];
    if (!(total > 0.0) || !isfinite(total)) {
        free(sum);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "no density to place particles in (total optical mass %g over %zu "
                              "voxels)",
                              total, count);
    }
    *prefix = sum;
    *mean_sigma_t = active ? sigma_sum / (double)active : total / (voxel_volume * (double)count);
    return VDBS_OK;
}

/* The voxel whose mass interval [prefix[n], prefix[n + 1]) holds `target`: never one of zero
 * mass, and the last massive voxel should rounding put target at the total. */
static size_t find_voxel(const double *prefix, size_t count, double target)
{
    size_t lo = 0, hi = count; /* the answer is the first n with prefix[n + 1] > target */
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (prefix[mid + 1] > target)
            hi = mid;
        else
            lo = mid + 1;
    }
    if (lo >= count) {
        lo = count - 1;
        while (lo > 0 && !(prefix[lo + 1] > prefix[lo]))
            --lo;
    }
    return lo;
}

static void sample_particles(const vdbs_volume *volume, const double *prefix, uint64_t seed,
                             int64_t particles, float *position, int64_t *voxel)
{
    const size_t count = volume->coord_count;
    const double total = prefix[count];
#pragma omp parallel for schedule(static)
    for (int64_t k = 0; k < particles; ++k) {
        const double target = ((double)k + hashed_uniform(seed, k, 0)) / (double)particles * total;
        const size_t n = find_voxel(prefix, count, target);
        const int32_t *c = volume->coords + 3 * n;
        double index[3], world[3];
        for (int a = 0; a < 3; ++a)
            index[a] = (double)c[a] + hashed_uniform(seed, k, 1 + a) - 0.5;
        vdbs_volume_world_point(volume, index, world);
        for (int a = 0; a < 3; ++a)
            position[3 * k + a] = (float)world[a];
        voxel[k] = (int64_t)n;
    }
}

/* The centre of the particles' axis-aligned bounds and the farthest particle from it, grown a
 * little so that every particle lies strictly inside, and never below half a voxel. */
static void bounding_sphere(const float *position, int64_t particles, double mean_voxel_size,
                            double centre[3], double *radius)
{
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int64_t k = 0; k < particles; ++k)
        for (int a = 0; a < 3; ++a) {
            const double p = position[3 * k + a];
            lo[a] = p < lo[a] ? p : lo[a];
            hi[a] = p > hi[a] ? p : hi[a];
        }
    for (int a = 0; a < 3; ++a)
        centre[a] = 0.5 * (lo[a] + hi[a]);
    double r2 = 0.0;
    for (int64_t k = 0; k < particles; ++k) {
        double d2 = 0.0;
        for (int a = 0; a < 3; ++a) {
            const double e = position[3 * k + a] - centre[a];
            d2 += e * e;
        }
        r2 = d2 > r2 ? d2 : r2;
    }
    const double r = sqrt(r2) * (1.0 + 1e-6);
    const double floor_r = 0.5 * mean_voxel_size;
    *radius = r > floor_r ? r : floor_r;
}

/* A particle's place in one direction's order: its pixel, then its depth, then its index. */
typedef struct inet_key {
    int64_t pixel;
    double depth;
    int32_t index;
} inet_key;

static int key_before(const inet_key *a, const inet_key *b)
{
    if (a->pixel != b->pixel)
        return a->pixel < b->pixel;
    if (a->depth != b->depth)
        return a->depth < b->depth;
    return a->index < b->index;
}

static int key_compare(const void *pa, const void *pb)
{
    const inet_key *a = pa, *b = pb;
    return key_before(a, b) ? -1 : key_before(b, a) ? 1 : 0;
}

/* Orders a bucket: most hold a handful of particles, where insertion beats qsort's calls. */
static void sort_bucket(inet_key *keys, size_t count)
{
    if (count > INET_INSERTION_MAX) {
        qsort(keys, count, sizeof *keys, key_compare);
        return;
    }
    for (size_t i = 1; i < count; ++i) {
        const inet_key k = keys[i];
        size_t j = i;
        for (; j > 0 && key_before(&k, &keys[j - 1]); --j)
            keys[j] = keys[j - 1];
        keys[j] = k;
    }
}

/* One thread's buffers, reused for every direction it takes. */
typedef struct inet_scratch {
    inet_key *keys;   /* N, in particle order */
    inet_key *sorted; /* N, by (pixel, depth, index) */
    size_t *start;    /* M^2 + 1 bucket starts: only when counting sort is used */
} inet_scratch;

/* Counting sort by pixel pays M^2 per direction; beyond a few buckets a particle, one qsort
 * of the whole array is cheaper (both give the same order). */
static int use_buckets(int64_t particles, int window)
{
    return (double)window * window <= 4.0 * (double)particles + 1024.0;
}

static void link_direction(const vdbs_inet_network *net, int d, inet_scratch *s)
{
    const int64_t n_part = net->particles;
    const int m = net->window;
    const double *w = net->dirs + 3 * d;
    double u[3], v[3];
    vdbs_inet_basis(w, u, v);
    const double r = net->radius;
    for (int64_t k = 0; k < n_part; ++k) {
        double e[3];
        for (int a = 0; a < 3; ++a)
            e[a] = (double)net->position[3 * k + a] - net->centre[a];
        const double x = e[0] * u[0] + e[1] * u[1] + e[2] * u[2];
        const double y = e[0] * v[0] + e[1] * v[1] + e[2] * v[2];
        double fx = floor((x + r) / (2.0 * r) * m), fy = floor((y + r) / (2.0 * r) * m);
        fx = fx < 0.0 ? 0.0 : fx > m - 1 ? m - 1 : fx;
        fy = fy < 0.0 ? 0.0 : fy > m - 1 ? m - 1 : fy;
        s->keys[k].pixel = (int64_t)fy * m + (int64_t)fx;
        s->keys[k].depth = e[0] * w[0] + e[1] * w[1] + e[2] * w[2];
        s->keys[k].index = (int32_t)k;
    }
    if (s->start) {
        const size_t pixels = (size_t)m * (size_t)m;
        memset(s->start, 0, sizeof *s->start * (pixels + 1));
        for (int64_t k = 0; k < n_part; ++k)
            ++s->start[s->keys[k].pixel + 1];
        for (size_t p = 0; p < pixels; ++p)
            s->start[p + 1] += s->start[p];
        /* Scattering in particle order keeps each bucket in index order (stable). */
        for (int64_t k = 0; k < n_part; ++k)
            s->sorted[s->start[s->keys[k].pixel]++] = s->keys[k];
        /* The scatter advanced every start to its bucket's end: bucket p is [end(p-1), end(p)). */
        size_t begin = 0;
        for (size_t p = 0; p < pixels; ++p) {
            const size_t end = s->start[p];
            if (end - begin > 1)
                sort_bucket(s->sorted + begin, end - begin);
            begin = end;
        }
    } else {
        memcpy(s->sorted, s->keys, sizeof *s->keys * (size_t)n_part);
        qsort(s->sorted, (size_t)n_part, sizeof *s->sorted, key_compare);
    }
    const int dirs = net->directions;
    for (int64_t j = 0; j < n_part; ++j) {
        const int32_t p = s->sorted[j].index;
        const int first = j == 0 || s->sorted[j - 1].pixel != s->sorted[j].pixel;
        net->upstream[(size_t)p * dirs + d] = first ? -1 : s->sorted[j - 1].index;
    }
}

/* Builds every direction's links, directions shared among threads; 0 when a thread could not
 * get its buffers. */
static int link_all(vdbs_inet_network *net)
{
    const size_t n_part = (size_t)net->particles;
    const int buckets = use_buckets(net->particles, net->window);
    int ok = 1;
#pragma omp parallel
    {
        inet_scratch s;
        s.keys = malloc(sizeof *s.keys * n_part);
        s.sorted = malloc(sizeof *s.sorted * n_part);
        s.start =
            buckets ? malloc(sizeof *s.start * ((size_t)net->window * net->window + 1)) : NULL;
        const int mine = s.keys && s.sorted && (!buckets || s.start);
        if (!mine) {
#pragma omp atomic write
            ok = 0;
        }
#pragma omp for schedule(dynamic, 1)
        for (int d = 0; d < net->directions; ++d)
            if (mine)
                link_direction(net, d, &s);
        free(s.keys);
        free(s.sorted);
        free(s.start);
    }
    return ok;
}

vdbs_status vdbs_inet_network_build(const vdbs_volume *volume, double density_scale,
                                    const double *dirs, int directions,
                                    const vdbs_inet_network_desc *desc, vdbs_inet_network *net,
                                    vdbs_error *err)
{
    memset(net, 0, sizeof *net);
    const int64_t n_part = desc->particles;
    if (n_part < 1 || n_part > INT32_MAX)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%lld particles: need 1 to %d",
                              (long long)n_part, INT32_MAX);
    if (directions < 1 || !dirs)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%d directions: need at least 1", directions);
    if (desc->window < 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "a window of %d pixels: need 0 (the rule) or "
                              "more",
                              desc->window);
    for (int d = 0; d < directions; ++d) {
        const double *w = dirs + 3 * d;
        const double len2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        if (!(fabs(len2 - 1.0) <= 1e-6))
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "direction %d (%g, %g, %g) is not of unit length", d, w[0], w[1],
                                  w[2]);
    }
    if (!(density_scale > 0.0) || !isfinite(density_scale))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "no density to place particles in (density scale %g)", density_scale);
    if (volume->coord_count == 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "no density to place particles in (no voxels)");
    double *prefix = NULL, mean_sigma_t = 0.0;
    net->voxel_sigma_t = malloc(sizeof *net->voxel_sigma_t * volume->coord_count);
    if (!net->voxel_sigma_t)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the masses of %zu voxels",
                              volume->coord_count);
    vdbs_status st =
        voxel_masses(volume, density_scale, &prefix, net->voxel_sigma_t, &mean_sigma_t, err);
    if (st != VDBS_OK) {
        vdbs_inet_network_free(net);
        return st;
    }
    const double total = prefix[volume->coord_count];
    net->particles = n_part;
    net->directions = directions;
    net->dirs = dirs;
    net->position = malloc(sizeof *net->position * 3 * (size_t)n_part);
    net->voxel = malloc(sizeof *net->voxel * (size_t)n_part);
    net->upstream = malloc(sizeof *net->upstream * (size_t)n_part * (size_t)directions);
    if (!net->position || !net->voxel || !net->upstream) {
        free(prefix);
        vdbs_inet_network_free(net);
        return vdbs_error_set(err, VDBS_ERR_NOMEM,
                              "out of memory for %lld particles in %d directions",
                              (long long)n_part, directions);
    }
    sample_particles(volume, prefix, desc->seed, n_part, net->position, net->voxel);
    free(prefix);
    net->mass = total / (double)n_part;
    bounding_sphere(net->position, n_part, volume->mean_voxel_size, net->centre, &net->radius);
    net->window = desc->window > 0 ? desc->window : vdbs_inet_window_rule(n_part);
    net->paper_window = vdbs_inet_paper_window(directions, net->radius, mean_sigma_t);
    const double side = 2.0 * net->radius / net->window;
    net->pixel_area = side * side;
    if (!link_all(net)) {
        const int window = net->window;
        vdbs_inet_network_free(net);
        return vdbs_error_set(err, VDBS_ERR_NOMEM,
                              "out of memory for the network's buffers (%lld particles, %d x %d "
                              "pixels)",
                              (long long)n_part, window, window);
    }
    return VDBS_OK;
}
