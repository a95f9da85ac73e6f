/* The illumination network's particles and links (vdbscatter/inet_network.h): sampling in
 * proportion to the voxel cubes' optical mass within the stratification's bound (per voxel and per
 * region), every particle inside its voxel under an anisotropic transform, the optical mass,
 * determinism over runs and thread counts, the links against a brute-force oracle (the pixel
 * recomputed from the basis, the upstream the previous particle by depth then index) and their
 * invariants (acyclic, one downstream at most, same pixel, smaller depth), also where depths tie
 * and on the comparison-sort path, the window rule on hand-computed cases, and bad input. */
#include "testutil.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "vdbscatter/inet_network.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/sphere.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

/* A 16 x 8 x 8 block at index (0, 0, 0), density 1 where i < 8 and 3 where i >= 8 (two of
 * OpenVDB's 8^3 leaves, so that each half is one run of the coords' leaf-by-leaf order),
 * voxels 0.1 x 0.12 x 0.08 with an offset, so that index and world differ on every axis. */
#define TWO_NX 16
#define TWO_NY 8
#define TWO_NZ 8

static void two_region_volume(vdbs_volume *volume)
{
    const int dims[3] = {TWO_NX, TWO_NY, TWO_NZ};
    float *values = malloc(sizeof *values * TWO_NX * TWO_NY * TWO_NZ);
    assert_non_null(values);
    for (int k = 0; k < TWO_NZ; ++k)
        for (int j = 0; j < TWO_NY; ++j)
            for (int i = 0; i < TWO_NX; ++i)
                values[(k * TWO_NY + j) * TWO_NX + i] = i < TWO_NX / 2 ? 1.0f : 3.0f;
    const int origin[3] = {0, 0, 0};
    vdbio_transform xf = {{{0.1, 0.0, 0.0, 0.25}, {0.0, 0.12, 0.0, -0.5}, {0.0, 0.0, 0.08, 1.0}}};
    test_dense_volume(values, dims, origin, &xf, volume);
}

static void sphere_volume(int res, vdbs_volume *volume)
{
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbs_sample_create("sphere", res, 1, &density, &err), VDBS_OK);
    assert_int_equal(vdbs_volume_from_density(density, volume, &err), VDBS_OK);
}

static void build(const vdbs_volume *volume, double scale, const double *dirs, int d, int64_t n,
                  int window, uint64_t seed, vdbs_inet_network *net)
{
    vdbs_inet_network_desc desc = {n, window, seed};
    vdbs_error err;
    if (vdbs_inet_network_build(volume, scale, dirs, d, &desc, net, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* The optical mass of every output voxel's cube under the trilinear density, read through
 * OpenVDB's tree (not the NanoVDB path the module reads): the hat function integrates to 3/4
 * over its own cube and 1/8 over each face neighbour's, per axis. And the total. */
static double *voxel_masses(const vdbs_volume *volume, double scale, double *total)
{
    static const double hat[3] = {0.125, 0.75, 0.125};
    double *mass = malloc(sizeof *mass * volume->coord_count);
    assert_non_null(mass);
    const double vv = vdbs_volume_voxel_volume(volume);
    *total = 0.0;
    for (size_t n = 0; n < volume->coord_count; ++n) {
        const int32_t *c = volume->coords + 3 * n;
        double sum = 0.0;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int ijk[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
                    sum += hat[dx + 1] * hat[dy + 1] * hat[dz + 1] *
                           fmax(vdbio_density_value(volume->density, ijk), 0.0);
                }
        mass[n] = scale * sum * vv;
        *total += mass[n];
    }
    return mass;
}

/* Stratified sampling puts particle k at CDF position (k + xi_k) / N. A contiguous run of the
 * CDF of length L (in units of M / N) then holds all k in [ceil(a), floor(b) - 1] and at most
 * floor(a) and floor(b) besides, so its count differs from L by less than 2: per voxel (one
 * run each), and per region by less than 2 per run of the region's voxels in coords order. */
static void test_sampling_proportional(void **state)
{
    (void)state;
    vdbs_volume volume;
    two_region_volume(&volume);
    const double scale = 2.5;
    double total;
    double *mass = voxel_masses(&volume, scale, &total);
    double dirs[3 * 4];
    vdbs_sphere_directions(4, dirs);
    const int64_t n = 10007;
    vdbs_inet_network net;
    build(&volume, scale, dirs, 4, n, 0, 7, &net);
    assert_true(test_rel_diff(net.mass * (double)n, total) <= 1e-9);
    /* The cubes' masses add up to the medium's: 8^3 voxels of density 1 and 8^3 of 3. */
    const double medium = scale * vdbs_volume_voxel_volume(&volume) * 8 * 8 * 8 * (1.0 + 3.0);
    assert_true(test_rel_diff(total, medium) <= 1e-9);

    const size_t count = volume.coord_count;
    int64_t *per_voxel = calloc(count, sizeof *per_voxel);
    assert_non_null(per_voxel);
    for (int64_t k = 0; k < n; ++k) {
        assert_true(net.voxel[k] >= 0 && (size_t)net.voxel[k] < count);
        ++per_voxel[net.voxel[k]];
    }
    double worst = 0.0, heavy_mass = 0.0;
    int64_t heavy = 0;
    int runs = 0, in_run = 0;
    for (size_t v = 0; v < count; ++v) {
        const double expected = (double)n * mass[v] / total;
        worst = fmax(worst, fabs((double)per_voxel[v] - expected));
        if (mass[v] == 0.0) {
            assert_int_equal(per_voxel[v], 0);
            continue; /* zero-mass voxels are empty CDF runs: they split no run */
        }
        const int is_heavy = volume.coords[3 * v] >= TWO_NX / 2;
        if (is_heavy) {
            heavy += per_voxel[v];
            heavy_mass += mass[v];
        }
        runs += is_heavy && !in_run;
        in_run = is_heavy;
    }
    assert_true(worst < 2.0);
    /* 3 times the density over half the voxels, i >= 8 with the ring at i = 16: 3/4 of the
     * mass less the eighth of slab 8's that falls in slab 7's cubes (3/8 of a slab of
     * density 1) plus the eighth of slab 7's in slab 8's (1/8), of 32 such slabs in all. */
    assert_true(fabs(heavy_mass / total - (24.0 - 0.375 + 0.125) / 32.0) < 1e-12);
    const double expected_heavy = (double)n * heavy_mass / total;
    print_message("per-voxel worst |count - N m / M| = %.3f; heavy half %lld particles, expected "
                  "%.3f, in %d run(s) of coords order\n",
                  worst, (long long)heavy, expected_heavy, runs);
    assert_true(runs >= 1);
    assert_true(fabs((double)heavy - expected_heavy) < 2.0 * runs);
    free(per_voxel);
    free(mass);
    vdbs_inet_network_free(&net);
    vdbs_volume_free(&volume);
}

/* Every particle in index space within half a voxel of its voxel's centre (integer coords),
 * uniformly: each axis's offsets fill both halves of the voxel. The bounding sphere holds
 * every particle. */
static void test_inside_voxel(void **state)
{
    (void)state;
    vdbs_volume volume;
    two_region_volume(&volume);
    double dirs[3 * 2];
    vdbs_sphere_directions(2, dirs);
    const int64_t n = 20000;
    vdbs_inet_network net;
    build(&volume, 1.0, dirs, 2, n, 0, 11, &net);
    double worst = 0.0, mean[3] = {0.0, 0.0, 0.0};
    for (int64_t k = 0; k < n; ++k) {
        const double world[3] = {net.position[3 * k], net.position[3 * k + 1],
                                 net.position[3 * k + 2]};
        double index[3];
        vdbs_volume_index_point(&volume, world, index);
        const int32_t *c = volume.coords + 3 * net.voxel[k];
        double r2 = 0.0;
        for (int a = 0; a < 3; ++a) {
            const double off = index[a] - c[a];
            worst = fmax(worst, fabs(off));
            mean[a] += off / (double)n;
            const double e = world[a] - net.centre[a];
            r2 += e * e;
        }
        assert_true(sqrt(r2) <= net.radius);
    }
    assert_true(worst <= 0.5 + 1e-4);
    /* 20000 uniform offsets: the mean's standard error is 0.29 / sqrt(20000) = 0.002. */
    for (int a = 0; a < 3; ++a)
        assert_true(fabs(mean[a]) < 0.01);
    assert_true(net.radius >= 0.5 * volume.mean_voxel_size);
    assert_true(net.window >= 1);
    const double side = 2.0 * net.radius / net.window;
    assert_true(test_rel_diff(net.pixel_area, side * side) <= 1e-12);
    vdbs_inet_network_free(&net);
    vdbs_volume_free(&volume);
}

static void assert_same(const vdbs_inet_network *a, const vdbs_inet_network *b)
{
    assert_int_equal(a->particles, b->particles);
    assert_int_equal(a->window, b->window);
    const size_t n = (size_t)a->particles;
    assert_memory_equal(a->position, b->position, sizeof *a->position * 3 * n);
    assert_memory_equal(a->voxel, b->voxel, sizeof *a->voxel * n);
    assert_memory_equal(a->upstream, b->upstream, sizeof *a->upstream * n * (size_t)a->directions);
    assert_true(a->mass == b->mass && a->radius == b->radius);
}

/* The same seed gives the same bits, on one thread and on two; another seed other positions
 * but the same mass. */
static void test_determinism(void **state)
{
    (void)state;
    vdbs_volume volume;
    sphere_volume(24, &volume);
    enum { D = 16 };
    double dirs[3 * D];
    vdbs_sphere_directions(D, dirs);
    const int threads = omp_get_max_threads();
    vdbs_inet_network a, b, c, other;
    build(&volume, 4.0, dirs, D, 5000, 0, 1, &a);
    build(&volume, 4.0, dirs, D, 5000, 0, 1, &b);
    assert_same(&a, &b);
    omp_set_num_threads(1);
    build(&volume, 4.0, dirs, D, 5000, 0, 1, &c);
    assert_same(&a, &c);
    vdbs_inet_network_free(&c);
    omp_set_num_threads(2);
    build(&volume, 4.0, dirs, D, 5000, 0, 1, &c);
    assert_same(&a, &c);
    omp_set_num_threads(threads);
    build(&volume, 4.0, dirs, D, 5000, 0, 2, &other);
    assert_true(memcmp(a.position, other.position, sizeof *a.position * 3 * 5000) != 0);
    assert_true(a.mass == other.mass);
    vdbs_inet_network_free(&a);
    vdbs_inet_network_free(&b);
    vdbs_inet_network_free(&c);
    vdbs_inet_network_free(&other);
    vdbs_volume_free(&volume);
}

/* The invariants of every direction's links, with no knowledge of the basis: a chain of
 * upstream links ends within N steps, no particle is upstream of two, the upstream particle
 * is not deeper (equal depth: smaller index) and within a pixel's diagonal of the particle
 * across the direction. Returns the number of chain heads (upstream -1) summed over d. */
static int64_t check_invariants(const vdbs_inet_network *net)
{
    const int64_t n = net->particles;
    const int dcount = net->directions;
    const double diagonal = 2.0 * net->radius / net->window * sqrt(2.0);
    int32_t *downstream = malloc(sizeof *downstream * (size_t)n);
    assert_non_null(downstream);
    int64_t heads = 0;
    for (int d = 0; d < dcount; ++d) {
        const double *w = net->dirs + 3 * d;
        memset(downstream, 0, sizeof *downstream * (size_t)n);
        for (int64_t p = 0; p < n; ++p) {
            const int32_t q = net->upstream[p * dcount + d];
            if (q < 0) {
                assert_int_equal(q, -1);
                ++heads;
                continue;
            }
            assert_true(q < n && q != p);
            ++downstream[q];
            double e[3], depth_p = 0.0, depth_q = 0.0, along = 0.0, len2 = 0.0;
            for (int a = 0; a < 3; ++a) {
                depth_p += ((double)net->position[3 * p + a] - net->centre[a]) * w[a];
                depth_q += ((double)net->position[3 * q + a] - net->centre[a]) * w[a];
                e[a] = (double)net->position[3 * p + a] - net->position[3 * q + a];
                along += e[a] * w[a];
            }
            assert_true(depth_q < depth_p || (depth_q == depth_p && q < p));
            for (int a = 0; a < 3; ++a) {
                const double perp = e[a] - along * w[a];
                len2 += perp * perp;
            }
            assert_true(sqrt(len2) <= diagonal * (1.0 + 1e-9));
        }
        for (int64_t p = 0; p < n; ++p)
            assert_true(downstream[p] <= 1);
        /* Strictly rising (depth, index) along a chain already rules out a cycle; walk the
         * chains anyway, bounded by N. */
        for (int64_t p = 0; p < n; ++p) {
            int64_t steps = 0;
            for (int32_t q = (int32_t)p; q >= 0; q = net->upstream[(int64_t)q * dcount + d])
                assert_true(++steps <= n);
        }
    }
    free(downstream);
    return heads;
}

/* The pixel of particle p for direction d from the documented layout (vdbs_inet_basis). */
static int64_t pixel_of(const vdbs_inet_network *net, const double u[3], const double v[3],
                        int64_t p)
{
    double e[3];
    for (int a = 0; a < 3; ++a)
        e[a] = (double)net->position[3 * p + a] - net->centre[a];
    const double x = e[0] * u[0] + e[1] * u[1] + e[2] * u[2];
    const double y = e[0] * v[0] + e[1] * v[1] + e[2] * v[2];
    const int m = net->window;
    const double r = net->radius;
    double ix = floor((x + r) / (2.0 * r) * m), iy = floor((y + r) / (2.0 * r) * m);
    ix = fmin(fmax(ix, 0.0), m - 1);
    iy = fmin(fmax(iy, 0.0), m - 1);
    return (int64_t)iy * m + (int64_t)ix;
}

/* Brute force on a small case: every particle's upstream is the particle of its pixel with
 * the largest (depth, index) below its own, or -1 when none; the heads are as many as the
 * non-empty pixels. */
static void check_oracle(const vdbs_inet_network *net)
{
    const int64_t n = net->particles;
    const int dcount = net->directions;
    const int m = net->window;
    int64_t *pixel = malloc(sizeof *pixel * (size_t)n);
    double *depth = malloc(sizeof *depth * (size_t)n);
    char *used = malloc((size_t)m * m);
    assert_true(pixel && depth && used);
    for (int d = 0; d < dcount; ++d) {
        const double *w = net->dirs + 3 * d;
        double u[3], v[3];
        vdbs_inet_basis(w, u, v);
        const double uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        const double uw = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
        const double vw = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
        const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        const double vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        assert_true(fabs(uv) < 1e-12 && fabs(uw) < 1e-12 && fabs(vw) < 1e-12);
        assert_true(fabs(uu - 1.0) < 1e-12 && fabs(vv - 1.0) < 1e-12);
        memset(used, 0, (size_t)m * m);
        int64_t nonempty = 0, heads = 0;
        for (int64_t p = 0; p < n; ++p) {
            pixel[p] = pixel_of(net, u, v, p);
            depth[p] = 0.0;
            for (int a = 0; a < 3; ++a)
                depth[p] += ((double)net->position[3 * p + a] - net->centre[a]) * w[a];
            nonempty += !used[pixel[p]];
            used[pixel[p]] = 1;
        }
        for (int64_t p = 0; p < n; ++p) {
            int64_t best = -1;
            for (int64_t q = 0; q < n; ++q) {
                if (pixel[q] != pixel[p])
                    continue;
                const int below = depth[q] < depth[p] || (depth[q] == depth[p] && q < p);
                const int above_best =
                    best < 0 || depth[q] > depth[best] || (depth[q] == depth[best] && q > best);
                if (below && above_best)
                    best = q;
            }
            assert_int_equal(net->upstream[p * dcount + d], best);
            heads += best < 0;
        }
        assert_int_equal(heads, nonempty);
    }
    free(pixel);
    free(depth);
    free(used);
}

static void test_network_oracle(void **state)
{
    (void)state;
    vdbs_volume volume;
    two_region_volume(&volume);
    enum { D = 8 };
    double dirs[3 * D];
    vdbs_sphere_directions(D, dirs);
    vdbs_inet_network net;
    build(&volume, 1.0, dirs, D, 500, 6, 3, &net);
    assert_int_equal(net.window, 6);
    assert_int_equal(net.directions, D);
    assert_ptr_equal(net.dirs, dirs);
    const int64_t heads = check_invariants(&net);
    assert_true(heads >= D && heads <= (int64_t)D * 36);
    check_oracle(&net);
    vdbs_inet_network_free(&net);
    /* More pixels than a few per particle: the comparison-sort path gives the same links. */
    build(&volume, 1.0, dirs, D, 500, 200, 3, &net);
    check_invariants(&net);
    check_oracle(&net);
    vdbs_inet_network_free(&net);
    /* Buckets over the insertion sort's length (qsort within a pixel). */
    build(&volume, 1.0, dirs, D, 500, 2, 3, &net);
    check_invariants(&net);
    check_oracle(&net);
    vdbs_inet_network_free(&net);
    vdbs_volume_free(&volume);
}

/* A larger network by the window rule: the invariants, and every particle first in exactly
 * one chain per direction (heads = chains). */
/* Ties in depth: one voxel of side 1e-3 at 1000, where floats take about 16 values an axis, so
 * that many particles share a depth (and whole positions): the order within a pixel falls back
 * on the index, in one pixel (qsort over the bucket) and over many (insertion). */
static void test_network_ties(void **state)
{
    (void)state;
    const float one = 2.0f;
    const int dims[3] = {1, 1, 1};
    vdbio_transform xf = {
        {{1e-3, 0.0, 0.0, 1000.0}, {0.0, 1e-3, 0.0, 1000.0}, {0.0, 0.0, 1e-3, 1000.0}}};
    vdbio_density *density = NULL;
    vdbs_error err;
    assert_int_equal(vdbio_density_from_dense(&one, dims, NULL, &xf, NULL, &density, &err),
                     VDBS_OK);
    vdbs_volume volume;
    assert_int_equal(vdbs_volume_from_density(density, &volume, &err), VDBS_OK);
    double dirs[3 * 3] = {1.0, 0.0, 0.0, 0.0, 0.0, -1.0};
    vdbs_sphere_directions(1, dirs + 6);
    const int windows[2] = {1, 40};
    for (int i = 0; i < 2; ++i) {
        vdbs_inet_network net;
        build(&volume, 1.0, dirs, 3, 2000, windows[i], 9, &net);
        int64_t ties = 0;
        for (int64_t p = 1; p < net.particles; ++p)
            ties += net.position[3 * p] == net.position[0];
        assert_true(ties > 10);
        check_invariants(&net);
        check_oracle(&net);
        vdbs_inet_network_free(&net);
    }
    vdbs_volume_free(&volume);
}

static void test_network_invariants(void **state)
{
    (void)state;
    vdbs_volume volume;
    sphere_volume(24, &volume);
    enum { D = 32 };
    double dirs[3 * D];
    vdbs_sphere_directions(D, dirs);
    vdbs_inet_network net;
    build(&volume, 8.0, dirs, D, 20000, 0, 5, &net);
    const int64_t heads = check_invariants(&net);
    assert_true(heads <= (int64_t)D * net.window * net.window);
    vdbs_inet_network_free(&net);

    /* The build's time at N = 1e5, D = 64, printed for the record (not asserted). */
    enum { DBIG = 64 };
    double big[3 * DBIG];
    vdbs_sphere_directions(DBIG, big);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    build(&volume, 8.0, big, DBIG, 100000, 0, 5, &net);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    print_message("N = 1e5, D = 64 on a 24^3 sphere (%zu voxels): M = %d, %.3f s on %d "
                  "thread(s)\n",
                  volume.coord_count, net.window,
                  (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec),
                  omp_get_max_threads());
    vdbs_inet_network_free(&net);
    vdbs_volume_free(&volume);
}

/* sqrt(D) R tau / sqrt(pi) against floor(sqrt(N / 4)), clamped to [1, 4096]. */
static void test_window_rule(void **state)
{
    (void)state;
    /* The paper's bound: sqrt(64) * 1 * 10 / sqrt(pi) = 45.135; sqrt(16) * 2 * 3 / sqrt(pi) =
     * 13.541. */
    assert_int_equal(vdbs_inet_paper_window(64, 1.0, 10.0), 45);
    assert_int_equal(vdbs_inet_paper_window(16, 2.0, 3.0), 13);
    /* Clamped to 1 (a thin medium, 8 * 0.1 * 0.1 / 1.77 = 0.045; no medium) and to 4096
     * (100 * 100 * 100 / 1.77; unbounded). */
    assert_int_equal(vdbs_inet_paper_window(64, 0.1, 0.1), 1);
    assert_int_equal(vdbs_inet_paper_window(64, 1.0, 0.0), 1);
    assert_int_equal(vdbs_inet_paper_window(10000, 100.0, 100.0), 4096);
    assert_int_equal(vdbs_inet_paper_window(64, 1.0, INFINITY), 4096);
    /* The default: sqrt(400 / 4) = 10 exactly, sqrt(399 / 4) = 9.987, sqrt(1e6 / 4) = 500, one
     * particle 1, sqrt(1e12 / 4) = 500000 clamped to 4096. */
    assert_int_equal(vdbs_inet_window_rule(400), 10);
    assert_int_equal(vdbs_inet_window_rule(399), 9);
    assert_int_equal(vdbs_inet_window_rule(1000000), 500);
    assert_int_equal(vdbs_inet_window_rule(1), 1);
    assert_int_equal(vdbs_inet_window_rule(1000000000000LL), 4096);
}

static void test_errors(void **state)
{
    (void)state;
    vdbs_volume volume;
    sphere_volume(8, &volume);
    double dirs[3 * 4];
    vdbs_sphere_directions(4, dirs);
    vdbs_inet_network net;
    vdbs_error err;
    vdbs_inet_network_desc desc = {0, 0, 0};
    assert_int_equal(vdbs_inet_network_build(&volume, 1.0, dirs, 4, &desc, &net, &err),
                     VDBS_ERR_INPUT);
    assert_null(net.position);
    desc.particles = (int64_t)INT32_MAX + 1;
    assert_int_equal(vdbs_inet_network_build(&volume, 1.0, dirs, 4, &desc, &net, &err),
                     VDBS_ERR_INPUT);
    desc.particles = 100;
    assert_int_equal(vdbs_inet_network_build(&volume, 1.0, dirs, 0, &desc, &net, &err),
                     VDBS_ERR_INPUT);
    assert_int_equal(vdbs_inet_network_build(&volume, 0.0, dirs, 4, &desc, &net, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "no density"));
    const double bad[3] = {1.0, 1.0, 0.0};
    assert_int_equal(vdbs_inet_network_build(&volume, 1.0, bad, 1, &desc, &net, &err),
                     VDBS_ERR_INPUT);
    vdbs_volume_free(&volume);

    /* A grid of zeros: no voxels, no density. */
    const float zero[8] = {0};
    const int dims[3] = {2, 2, 2};
    vdbio_density *density = NULL;
    assert_int_equal(vdbio_density_from_dense(zero, dims, NULL, NULL, NULL, &density, &err),
                     VDBS_OK);
    vdbs_volume empty;
    assert_int_equal(vdbs_volume_from_density(density, &empty, &err), VDBS_OK);
    assert_int_equal(vdbs_inet_network_build(&empty, 1.0, dirs, 4, &desc, &net, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "no density"));
    vdbs_volume_free(&empty);
    /* Freeing a zeroed network, twice. */
    vdbs_inet_network_free(&net);
    vdbs_inet_network_free(&net);
    assert_null(net.upstream);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sampling_proportional), cmocka_unit_test(test_inside_voxel),
        cmocka_unit_test(test_determinism),           cmocka_unit_test(test_network_oracle),
        cmocka_unit_test(test_network_ties),          cmocka_unit_test(test_network_invariants),
        cmocka_unit_test(test_window_rule),           cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
