/* Principal-Ordinates Propagation (vdbscatter/pop.h, shaders/vs_pop.h): the HG CDF against
 * quadrature, the stencil's fractions, the scheme against an independent double-precision
 * implementation of Eqs. 2-6 written here, and energy conservation without absorption on
 * rectilinear and radial grids. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"
#include "vdbscatter/importance.h"
#include "vdbscatter/pop.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_pop.h"

static const double PI = 3.14159265358979323846;

/* The fraction of an HG(a) lobe's power with mu <= m, by Simpson's rule in double. */
static double cdf_quadrature(double m, double a)
{
    const int n = 20000;
    double h = (m + 1.0) / n, s = 0.0;
    for (int i = 0; i <= n; ++i) {
        double mu = -1.0 + i * h;
        double f = 2.0 * PI * (1.0 - a * a) / (4.0 * PI * pow(1.0 + a * a - 2.0 * a * mu, 1.5));
        s += f * (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
    }
    return s * h / 3.0;
}

static void test_hg_cdf(void **state)
{
    (void)state;
    const double as[] = {-0.95, -0.5, -2e-3, -5e-4, 0.0, 5e-4, 2e-3, 0.3, 0.85, 0.99};
    const double ms[] = {-0.9, -0.70710678, 0.0, 0.5, 0.70710678, 0.95};
    for (size_t i = 0; i < sizeof as / sizeof as[0]; ++i)
        for (size_t j = 0; j < sizeof ms / sizeof ms[0]; ++j) {
            double want = cdf_quadrature(ms[j], as[i]);
            double got = vs_pop_hg_cdf((float)ms[j], (float)as[i]);
            if (fabs(got - want) > 2e-6)
                fail_msg("C(%g, %g) = %.8f, quadrature %.8f", ms[j], as[i], got, want);
        }
    /* Continuous through a = 0 (the textbook form divides by a there). */
    for (int s = -1; s <= 1; s += 2)
        assert_true(fabs(vs_pop_hg_cdf(0.70710678f, s * 1e-7f) - vs_pop_hg_cdf(0.70710678f, 0.0f)) <
                    1e-6);
}

static void test_fractions(void **state)
{
    (void)state;
    for (int i = -99; i <= 99; ++i) {
        float a = i / 100.0f;
        double sum = vs_pop_front(a) + vs_pop_back(a) + 4.0 * vs_pop_side(a);
        if (fabs(sum - 1.0) > 2e-6)
            fail_msg("a = %g: the six fractions sum to %.8f", a, sum);
        assert_true(vs_pop_front(a) >= 0.0f && vs_pop_back(a) >= 0.0f && vs_pop_side(a) >= 0.0f);
    }
    /* Isotropic light: the cone and band areas over 4 pi. */
    assert_true(fabs(vs_pop_front(0.0f) - (1.0 - sqrt(0.5)) / 2.0) < 1e-6);
    assert_true(fabs(vs_pop_side(0.0f) - sqrt(0.5) / 4.0) < 1e-6);
    /* Mean chords: a beam along an axis crosses one side, isotropic light 4V/S = 2/3. */
    assert_true(fabs(vs_pop_chord(0.0f) - 2.0 / 3.0) < 1e-7);
    assert_true(vs_pop_chord(1.0f) == 1.0f && vs_pop_chord(-1.0f) == 1.0f);
}

/* ---- an independent implementation of the discrete equations (double) ---- */

typedef struct grid {
    int n[3];
    double h, g, albedo[3];
    int paper;
    int chord; /* tally crossings by the lobe's mean chord (vs_pop_chord) */
    double *sigma;
    double *l, *a, *acc_l, *acc_la; /* 3 per cell */
} grid;

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double cdf_closed(double m, double a)
{
    if (a == 0.0)
        return 0.5 * (1.0 + m);
    return (1.0 - a * a) / (2.0 * a) * (1.0 / sqrt(1.0 + a * a - 2.0 * a * m) - 1.0 / (1.0 + a));
}

/* Eq. 3's three patches: front theta in [0, pi/4], side a quarter of [pi/4, 3 pi/4], back. */
static double patch(double a, int which)
{
    double c = cos(PI / 4.0);
    if (which == 0)
        return 1.0 - cdf_closed(c, a);
    if (which == 2)
        return cdf_closed(-c, a);
    return 0.25 * (cdf_closed(c, a) - cdf_closed(-c, a));
}

static void grid_step(const grid *gr, grid *out)
{
    const int n0 = gr->n[0], n1 = gr->n[1], n2 = gr->n[2];
    for (int k = 0; k < n2; ++k)
        for (int j = 0; j < n1; ++j)
            for (int i = 0; i < n0; ++i) {
                int dst = (k * n1 + j) * n0 + i;
                for (int c = 0; c < 3; ++c) {
                    double sl = 0.0, sla = 0.0;
                    for (int s = 0; s < 6; ++s) {
                        int d[3] = {0, 0, 0};
                        d[s / 2] = s % 2 ? 1 : -1;
                        int si = i + d[0], sj = j + d[1], sk = k + d[2];
                        if (si < 0 || sj < 0 || sk < 0 || si >= n0 || sj >= n1 || sk >= n2)
                            continue;
                        int src = (sk * n1 + sj) * n0 + si;
                        /* src behind dst along axis 2 sends its front patch, in front its
                         * back patch, beside it a side patch. */
                        int which = s == 4 ? 0 : (s == 5 ? 2 : 1);
                        double sig = 0.5 * (gr->sigma[src] + gr->sigma[dst]);
                        double dl = gr->l[3 * src + c] * patch(gr->a[3 * src + c], which) *
                                    exp(-sig * (1.0 - gr->albedo[c]) * gr->h);
                        double ts = sig * gr->albedo[c] * gr->h;
                        double da = gr->paper ? gr->a[3 * src + c] * pow(gr->g, ts)
                                              : gr->a[3 * src + c] * exp(-ts * (1.0 - gr->g));
                        sl += dl;
                        sla += dl * da;
                    }
                    out->l[3 * dst + c] = sl;
                    out->a[3 * dst + c] = sl > 0.0 ? sla / sl : 0.0;
                    /* Mean chord in cell sides: 1 along an axis, 4V/S = 2/3 isotropic. */
                    double chord =
                        gr->chord ? (2.0 + fmin(fabs(out->a[3 * dst + c]), 1.0)) / 3.0 : 1.0;
                    out->acc_l[3 * dst + c] = gr->acc_l[3 * dst + c] + sl * chord;
                    out->acc_la[3 * dst + c] =
                        gr->acc_la[3 * dst + c] + sl * chord * out->a[3 * dst + c];
                }
            }
}

static void grid_alloc(grid *g, int n0, int n1, int n2)
{
    memset(g, 0, sizeof *g);
    g->n[0] = n0;
    g->n[1] = n1;
    g->n[2] = n2;
    size_t cells = (size_t)n0 * n1 * n2;
    g->sigma = calloc(cells, sizeof(double));
    g->l = calloc(3 * cells, sizeof(double));
    g->a = calloc(3 * cells, sizeof(double));
    g->acc_l = calloc(3 * cells, sizeof(double));
    g->acc_la = calloc(3 * cells, sizeof(double));
    assert_non_null(g->acc_la);
}

static void grid_free(grid *g)
{
    free(g->sigma);
    free(g->l);
    free(g->a);
    free(g->acc_l);
    free(g->acc_la);
}

/* A random grid: sparse light, anisotropies in (-0.3, 0.95), sigma_t in [0, 4]. */
static void grid_random(grid *g, double albedo, double gg, int paper)
{
    size_t cells = (size_t)g->n[0] * g->n[1] * g->n[2];
    g->h = 0.25;
    g->g = gg;
    g->paper = paper;
    g->albedo[0] = albedo;
    g->albedo[1] = albedo * 0.9;
    g->albedo[2] = albedo * 0.8;
    for (size_t c = 0; c < cells; ++c) {
        g->sigma[c] = test_uniform(&rng_state) < 0.2 ? 0.0 : 4.0 * test_uniform(&rng_state);
        for (int ch = 0; ch < 3; ++ch) {
            g->l[3 * c + ch] = test_uniform(&rng_state) < 0.3 ? test_uniform(&rng_state) : 0.0;
            g->a[3 * c + ch] = -0.3 + 1.25 * test_uniform(&rng_state);
            g->acc_l[3 * c + ch] = 0.5 * g->l[3 * c + ch];
            g->acc_la[3 * c + ch] = 0.5 * g->l[3 * c + ch] * g->a[3 * c + ch];
        }
    }
}

static void pack(const grid *g, uint32_t params[VS_POP_PARAM_WORDS], float *sigma, float *state)
{
    memset(params, 0, sizeof(uint32_t) * VS_POP_PARAM_WORDS);
    for (int a = 0; a < 3; ++a)
        params[VS_POP_OFF_N + a] = (uint32_t)g->n[a];
    float h = (float)g->h, gg = (float)g->g;
    memcpy(&params[VS_POP_OFF_H], &h, 4);
    memcpy(&params[VS_POP_OFF_G], &gg, 4);
    for (int c = 0; c < 3; ++c) {
        float al = (float)g->albedo[c];
        memcpy(&params[VS_POP_OFF_ALBEDO + c], &al, 4);
    }
    params[VS_POP_OFF_DECAY] = g->paper ? VS_POP_DECAY_PAPER : VS_POP_DECAY_MEAN_COSINE;
    params[VS_POP_OFF_KEEP_A] = 1u;
    params[VS_POP_OFF_CHORD] = g->chord ? 1u : 0u;
    size_t cells = (size_t)g->n[0] * g->n[1] * g->n[2];
    for (size_t c = 0; c < cells; ++c) {
        sigma[c] = (float)g->sigma[c];
        for (int ch = 0; ch < 3; ++ch) {
            float *s = state + c * VS_POP_STATE_WORDS;
            s[VS_POP_STATE_L + ch] = (float)g->l[3 * c + ch];
            s[VS_POP_STATE_A + ch] = (float)g->a[3 * c + ch];
            s[VS_POP_STATE_ACC_L + ch] = (float)g->acc_l[3 * c + ch];
            s[VS_POP_STATE_ACC_LA + ch] = (float)g->acc_la[3 * c + ch];
        }
    }
}

static void compare(const char *what, double want, float got, double scale)
{
    if (fabs(got - want) > 1e-4 * fmax(fabs(want), scale))
        fail_msg("%s: %.8g against the independent %.8g", what, (double)got, want);
}

/* POP's kernel against the double implementation, `steps` iterations on n^3-ish grids. */
static void scheme_case(int n0, int n1, int n2, double albedo, double g, int paper, int chord,
                        int steps)
{
    grid a, b;
    grid_alloc(&a, n0, n1, n2);
    grid_alloc(&b, n0, n1, n2);
    grid_random(&a, albedo, g, paper);
    b.h = a.h;
    b.g = a.g;
    b.paper = a.paper;
    a.chord = b.chord = chord;
    memcpy(b.albedo, a.albedo, sizeof a.albedo);
    size_t cells = (size_t)n0 * n1 * n2;
    memcpy(b.sigma, a.sigma, cells * sizeof(double));
    uint32_t params[VS_POP_PARAM_WORDS];
    float *sigma = malloc(cells * sizeof(float));
    float *state = malloc(cells * VS_POP_STATE_WORDS * sizeof(float));
    pack(&a, params, sigma, state);
    for (int s = 0; s < steps; ++s) {
        grid_step(s % 2 ? &b : &a, s % 2 ? &a : &b);
    }
    const grid *want = steps % 2 ? &b : &a;
    vdbs_error err;
    int iterations = 0;
    double left = 0.0;
    assert_int_equal(vdbs_pop_propagate(test_runner(VDBS_BACKEND_CPU), params, VS_POP_PARAM_WORDS,
                                        sigma, (int64_t)cells, state, steps, 0.0, &iterations,
                                        &left, &err),
                     VDBS_OK);
    assert_int_equal(iterations, steps);
    double max_l = 0.0, sum = 0.0;
    for (size_t c = 0; c < 3 * cells; ++c) {
        max_l = fmax(max_l, want->acc_l[c]);
        sum += want->l[c];
    }
    for (size_t c = 0; c < cells; ++c)
        for (int ch = 0; ch < 3; ++ch) {
            const float *s = state + c * VS_POP_STATE_WORDS;
            size_t v = 3 * c + ch;
            compare("L", want->l[v], s[VS_POP_STATE_L + ch], 1e-3 * max_l);
            if (want->l[v] > 1e-3 * max_l)
                compare("a", want->a[v], s[VS_POP_STATE_A + ch], 1e-2);
            compare("acc L", want->acc_l[v], s[VS_POP_STATE_ACC_L + ch], 1e-3 * max_l);
            compare("acc L a", want->acc_la[v], s[VS_POP_STATE_ACC_LA + ch], 1e-3 * max_l);
        }
    assert_true(fabs(left - sum) <= 1e-4 * sum);
    print_message("%dx%dx%d, albedo %.2f, g %.2f, %s decay, %s tally, %d steps: agrees to 1e-4\n",
                  n0, n1, n2, albedo, g, paper ? "paper" : "mean-cosine", chord ? "chord" : "cell",
                  steps);
    free(sigma);
    free(state);
    grid_free(&a);
    grid_free(&b);
}

static void test_scheme(void **state)
{
    (void)state;
    scheme_case(8, 8, 8, 0.9, 0.85, 0, 1, 6);
    scheme_case(12, 9, 16, 0.6, 0.3, 1, 0, 5);
    scheme_case(16, 16, 16, 0.99, -0.4, 0, 1, 4);
    scheme_case(10, 14, 8, 0.8, 0.0, 1, 0, 3);
    scheme_case(9, 8, 12, 0.95, 0.6, 0, 0, 5);
    scheme_case(8, 10, 9, 0.7, 0.0, 1, 1, 4);
}

/* Without absorption an iteration only moves energy: after every iteration the energy in
 * the grid plus the energy that has left through its faces (tallied here in double from the
 * lobes before the step) equals the seeded energy to 1e-5. */
static void test_energy(void **state)
{
    (void)state;
    grid gr;
    const int n0 = 10, n1 = 12, n2 = 9;
    grid_alloc(&gr, n0, n1, n2);
    grid_random(&gr, 1.0, 0.85, 0);
    gr.albedo[1] = gr.albedo[2] = 1.0;
    size_t cells = (size_t)n0 * n1 * n2;
    uint32_t params[VS_POP_PARAM_WORDS];
    float *sigma = malloc(cells * sizeof(float));
    float *st = malloc(cells * VS_POP_STATE_WORDS * sizeof(float));
    pack(&gr, params, sigma, st);
    double seeded = 0.0, left_grid = 0.0;
    for (size_t c = 0; c < cells; ++c)
        for (int ch = 0; ch < 3; ++ch)
            seeded += st[c * VS_POP_STATE_WORDS + VS_POP_STATE_L + ch];
    for (int it = 0; it < 40; ++it) {
        /* What the step sends out of the grid: patches towards missing neighbours. */
        for (int k = 0; k < n2; ++k)
            for (int j = 0; j < n1; ++j)
                for (int i = 0; i < n0; ++i) {
                    const float *s = st + ((size_t)(k * n1 + j) * n0 + i) * VS_POP_STATE_WORDS;
                    for (int ch = 0; ch < 3; ++ch) {
                        double l = s[VS_POP_STATE_L + ch], a = s[VS_POP_STATE_A + ch];
                        int sides = (i == 0) + (i == n0 - 1) + (j == 0) + (j == n1 - 1);
                        left_grid += l * (sides * patch(a, 1) + (k == n2 - 1) * patch(a, 0) +
                                          (k == 0) * patch(a, 2));
                    }
                }
        vdbs_error err;
        int iterations = 0;
        double in_transit = 0.0;
        assert_int_equal(vdbs_pop_propagate(test_runner(VDBS_BACKEND_CPU), params,
                                            VS_POP_PARAM_WORDS, sigma, (int64_t)cells, st, 1, 0.0,
                                            &iterations, &in_transit, &err),
                         VDBS_OK);
        double inside = 0.0;
        for (size_t c = 0; c < cells; ++c)
            for (int ch = 0; ch < 3; ++ch)
                inside += st[c * VS_POP_STATE_WORDS + VS_POP_STATE_L + ch];
        if (fabs(inside + left_grid - seeded) > 1e-5 * seeded)
            fail_msg("iteration %d: %.9g in the grid + %.9g gone = %.9g, seeded %.9g", it + 1,
                     inside, left_grid, inside + left_grid, seeded);
        if (it == 39)
            print_message("albedo 1: after 40 iterations %.3f%% of the seeded energy is still "
                          "in the grid, the rest left it; balance to %.1e\n",
                          100.0 * inside / seeded, fabs(inside + left_grid - seeded) / seeded);
    }
    free(sigma);
    free(st);
    grid_free(&gr);
}

/* Radial grids (Sec. 6): without absorption, after every iteration the power in the grid,
 * sum of L A(cell), plus what has left through the outer shell (tallied here in double from
 * the lobes before the step: front fraction times L A) equals the seeded power to 1e-5, on
 * octahedral grids of 8, 16 and 32 shells with random media and lobes (negative anisotropies
 * send light through the centre into the antipodal texels). Without the radial compensation
 * (L scaled by A(src) / A(dst)) the same balance is off by more than 1%. */
static double radial_balance(int shells, int compensate, int iterations, double *worst)
{
    vdbs_radial_frame f;
    vdbs_error err;
    const double centre[3] = {0.1, -0.2, 0.3};
    assert_int_equal(vdbs_radial_octahedral(centre, shells, shells, 0.0, 2.0, &f, &err), VDBS_OK);
    const double albedo[3] = {1.0, 1.0, 1.0};
    vdbs_pop_transport desc = {0};
    size_t words = 0;
    uint32_t *params = vdbs_pop_radial_params(&f, 0.85, albedo, &desc, &words);
    assert_non_null(params);
    params[VS_POP_OFF_COMPENSATE] = compensate ? 1u : 0u;
    const int64_t cells = vdbs_radial_cells(&f), texels = (int64_t)shells * shells;
    float *sigma = malloc(sizeof(float) * (size_t)cells);
    float *st = calloc((size_t)cells * VS_POP_STATE_WORDS, sizeof(float));
    double *area = malloc(sizeof(double) * (size_t)cells);
    assert_true(sigma && st && area);
    double seeded = 0.0;
    for (int64_t c = 0; c < cells; ++c) {
        area[c] = vdbs_radial_cell_area(&f, c);
        sigma[c] = test_uniform(&rng_state) < 0.2 ? 0.0f : (float)(4.0 * test_uniform(&rng_state));
        for (int ch = 0; ch < 3; ++ch) {
            float *cell = st + c * VS_POP_STATE_WORDS;
            cell[VS_POP_STATE_L + ch] =
                test_uniform(&rng_state) < 0.3 ? (float)test_uniform(&rng_state) : 0.0f;
            cell[VS_POP_STATE_A + ch] = (float)(-0.6 + 1.55 * test_uniform(&rng_state));
            seeded += cell[VS_POP_STATE_L + ch] * area[c];
        }
    }
    double gone = 0.0, inside = 0.0;
    *worst = 0.0;
    for (int it = 0; it < iterations; ++it) {
        for (int64_t c = cells - texels; c < cells; ++c)
            for (int ch = 0; ch < 3; ++ch) {
                const float *cell = st + c * VS_POP_STATE_WORDS;
                gone += cell[VS_POP_STATE_L + ch] * patch(cell[VS_POP_STATE_A + ch], 0) * area[c];
            }
        int ran = 0;
        double in_transit = 0.0;
        assert_int_equal(vdbs_pop_propagate(test_runner(VDBS_BACKEND_CPU), params, words, sigma,
                                            cells, st, 1, 0.0, &ran, &in_transit, &err),
                         VDBS_OK);
        inside = 0.0;
        for (int64_t c = 0; c < cells; ++c)
            for (int ch = 0; ch < 3; ++ch)
                inside += st[c * VS_POP_STATE_WORDS + VS_POP_STATE_L + ch] * area[c];
        assert_true(fabs(in_transit - inside) <= 1e-4 * seeded);
        *worst = fmax(*worst, fabs(inside + gone - seeded) / seeded);
    }
    free(params);
    free(sigma);
    free(st);
    free(area);
    vdbs_radial_free(&f);
    return inside / seeded;
}

/* The octahedral map's topology as the kernel walks it (vs_pop_texel_step, vs_pop_antipode):
 * every texel's four neighbours, across the folded edges too, lie within two texel widths of
 * it and count it among their own neighbours, and its antipode looks the opposite way (the
 * texel centres' directions from the frame, computed independently of the kernel). */
static void test_octahedral_topology(void **state)
{
    (void)state;
    vdbs_radial_frame f;
    vdbs_error err;
    const double centre[3] = {0.0, 0.0, 0.0}, albedo[3] = {1.0, 1.0, 1.0};
    const int n = 16;
    assert_int_equal(vdbs_radial_octahedral(centre, n, 4, 0.0, 1.0, &f, &err), VDBS_OK);
    vdbs_pop_transport desc = {0};
    size_t words = 0;
    uint32_t *params = vdbs_pop_radial_params(&f, 0.5, albedo, &desc, &words);
    assert_non_null(params);
    double widest = 0.0, far = 0.0, anti = 1.0;
    for (int t = 0; t < n * n; ++t)
        widest = fmax(widest, sqrt(f.omega[t]));
    for (int t = 0; t < n * n; ++t) {
        const double *a = f.dir + 3 * t;
        for (int s = 0; s < 4; ++s) {
            int di = s == 0 ? -1 : (s == 1 ? 1 : 0), dj = s == 2 ? -1 : (s == 3 ? 1 : 0);
            int nb = vs_pop_texel_step(params, t % n, t / n, di, dj);
            assert_true(nb >= 0 && nb < n * n && nb != t);
            const double *b = f.dir + 3 * nb;
            far = fmax(far, acos(fmin(1.0, a[0] * b[0] + a[1] * b[1] + a[2] * b[2])));
            int back = 0;
            for (int q = 0; q < 4; ++q)
                back |= vs_pop_texel_step(params, nb % n, nb / n, q == 0 ? -1 : (q == 1 ? 1 : 0),
                                          q == 2 ? -1 : (q == 3 ? 1 : 0)) == t;
            assert_true(back);
        }
        const double *o = f.dir + 3 * vs_pop_antipode(params, t % n, t / n);
        anti = fmin(anti, -(a[0] * o[0] + a[1] * o[1] + a[2] * o[2]));
    }
    print_message("%d x %d texels: neighbours at most %.2f texel widths apart, antipodes "
                  "opposite to %.1e\n",
                  n, n, far / widest, 1.0 - anti);
    assert_true(far < 2.0 * widest);
    assert_true(anti > 1.0 - 1e-9);
    free(params);
    vdbs_radial_free(&f);
}

static void test_radial_energy(void **state)
{
    (void)state;
    const int shells[3] = {8, 16, 32};
    for (int q = 0; q < 3; ++q) {
        double worst = 0.0, off = 0.0;
        double left = radial_balance(shells[q], 1, 3 * shells[q], &worst);
        if (worst > 1e-5)
            fail_msg("%d shells: leaving + remaining differs from seeded by %.2e", shells[q],
                     worst);
        radial_balance(shells[q], 0, 3 * shells[q], &off);
        assert_true(off > 1e-2);
        print_message("%d^3 radial grid, %d iterations: balance to %.1e (%.1f%% still inside); "
                      "without the compensation off by %.1f%%\n",
                      shells[q], 3 * shells[q], worst, 100.0 * left, 100.0 * off);
    }
}

/* The camera's importance (Sec. 5.2) on the cloud sample (g 0.85: forward scattering): the
 * sky the picture depends on most lies behind the cloud as the camera sees it, so the map's
 * solid-angle-weighted mean direction points along the camera's view (cosine > 0.3) for two
 * opposite cameras; and POP's sky ordinates drawn from the bundled sky map times each map
 * differ, while those without importance do not depend on the camera. */
static void importance_case(const vdbs_volume *volume, vdbs_scene *scene, const double eye[3],
                            double *dirs, vdbs_runner *runner)
{
    vdbs_error err;
    scene->camera.present = 1;
    memcpy(scene->camera.position, eye, sizeof scene->camera.position);
    memset(scene->camera.target, 0, sizeof scene->camera.target);
    vdbs_medium_box box;
    assert_int_equal(vdbs_medium_box_build(volume, 4, &box, &err), VDBS_OK);
    vdbs_envmap map;
    vdbs_importance_stats stats;
    assert_int_equal(vdbs_importance_map(runner, volume, scene, &box, &map, &stats, &err), VDBS_OK);
    double mean[3] = {0.0, 0.0, 0.0}, lo = HUGE_VAL, hi = 0.0;
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x) {
            double d[3], v = map.rgb[3 * (y * map.width + x)];
            vdbs_envmap_direction(&map, x, y, d);
            for (int a = 0; a < 3; ++a)
                mean[a] += v * vdbs_envmap_texel_solid_angle(&map, x, y) * d[a];
            lo = fmin(lo, v);
            hi = fmax(hi, v);
        }
    double view[3] = {-eye[0], -eye[1], -eye[2]};
    double cosine = (mean[0] * view[0] + mean[1] * view[1] + mean[2] * view[2]) /
                    sqrt((mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]) *
                         (view[0] * view[0] + view[1] * view[1] + view[2] * view[2]));
    print_message("camera at (%.1f, %.1f, %.1f): %lld frustum cells, %d iterations, map %.2f to "
                  "%.2f, its mean direction at cosine %.2f to the view\n",
                  eye[0], eye[1], eye[2], stats.cells, stats.iterations, lo, hi, cosine);
    assert_true(lo >= VDBS_IMPORTANCE_FLOOR - 1e-6);
    assert_true(cosine > 0.3);
    vdbs_lights_desc ld = {.sky_ordinates = 8, .importance = &map};
    vdbs_light_table lights;
    assert_int_equal(vdbs_lights_build(volume, scene, &ld, &lights, &err), VDBS_OK);
    assert_int_equal(lights.ordinate_count, 8);
    for (int k = 0; k < 8; ++k)
        memcpy(dirs + 3 * k, lights.ordinates[k].world, 3 * sizeof(double));
    vdbs_lights_free(&lights);
    ld.importance = NULL;
    assert_int_equal(vdbs_lights_build(volume, scene, &ld, &lights, &err), VDBS_OK);
    for (int k = 0; k < 8; ++k)
        memcpy(dirs + 24 + 3 * k, lights.ordinates[k].world, 3 * sizeof(double));
    vdbs_lights_free(&lights);
    vdbs_envmap_free(&map);
    vdbs_medium_box_free(&box);
}

static void test_importance(void **state)
{
    (void)state;
    vdbs_volume volume;
    test_sample_volume("cloud", 48, 1, &volume);
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    scene.density_scale = 20.0;
    scene.albedo[0] = scene.albedo[1] = scene.albedo[2] = 0.99;
    scene.g = 0.85;
    scene.camera.up[1] = 1.0;
    scene.camera.fov_deg = 35.0;
    scene.camera.width = 320;
    scene.camera.height = 240;
    vdbs_light *sky = &scene.lights[scene.light_count++];
    memset(sky, 0, sizeof *sky);
    sky->type = VDBS_LIGHT_ENV;
    sky->env_scale = 1.0;
    vdbs_error err;
    assert_int_equal(vdbs_light_set_env_file(&scene, sky, VDBS_TEST_SAMPLES_DIR "/sky.exr", &err),
                     VDBS_OK);
    double a[48], b[48];
    const double front[3] = {-1.9, -0.6, -4.0}, back[3] = {1.9, 0.6, 4.0};
    importance_case(&volume, &scene, front, a, test_runner(VDBS_BACKEND_CPU));
    importance_case(&volume, &scene, back, b, test_runner(VDBS_BACKEND_CPU));
    double moved = 0.0, plain = 0.0;
    for (int k = 0; k < 24; ++k) {
        moved = fmax(moved, fabs(a[k] - b[k]));
        plain = fmax(plain, fabs(a[24 + k] - b[24 + k]));
    }
    print_message("ordinates with importance moved by up to %.3f with the camera; without, %.3f\n",
                  moved, plain);
    assert_true(moved > 0.1);
    assert_true(plain == 0.0);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hg_cdf),
        cmocka_unit_test(test_fractions),
        cmocka_unit_test(test_scheme),
        cmocka_unit_test(test_energy),
        cmocka_unit_test(test_octahedral_topology),
        cmocka_unit_test(test_radial_energy),
        cmocka_unit_test(test_importance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
