#define _POSIX_C_SOURCE 200809L /* dlopen */
#include "vdbscatter/phasemat.h"

#include <dlfcn.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/sphere.h"
#include "base/vdbs_math.h"

/* Sinkhorn sweeps at most, and the row-sum error that stops them. */
#define PHASEMAT_BALANCE_SWEEPS 10000
#define PHASEMAT_BALANCE_TOLERANCE 1e-14

/* OpenBLAS's thread count, where the BLAS under LAPACKE is OpenBLAS (else NULL): found at run
 * time, so that any BLAS still links. */
typedef void (*blas_set_threads)(int);
typedef int (*blas_get_threads)(void);

static void openblas_threads(blas_set_threads *set, blas_get_threads *get)
{
    *set = NULL;
    *get = NULL;
    void *self = dlopen(NULL, RTLD_LAZY);
    if (!self)
        return;
    void *s = dlsym(self, "openblas_set_num_threads"), *g = dlsym(self, "openblas_get_num_threads");
    if (s && g) {
        /* memcpy: ISO C has no cast from an object pointer to a function pointer. */
        memcpy(set, &s, sizeof *set);
        memcpy(get, &g, sizeof *get);
    }
    dlclose(self);
}

/* dsyevd on one BLAS thread: threaded OpenBLAS splits its products by the thread count
 * (OMP_NUM_THREADS), which changes their summation order and so the eigenvectors' last bits,
 * and with them every SVD bake's grids; one thread makes the factorisation the same whatever
 * the thread count (docs/robustness.md#determinism). */
static lapack_int eigensolve(int d, double *vec, double *s)
{
    blas_set_threads set;
    blas_get_threads get;
    openblas_threads(&set, &get);
    const int threads = get ? get() : 1;
    if (set)
        set(1);
    lapack_int info = LAPACKE_dsyevd(LAPACK_ROW_MAJOR, 'V', 'U', d, vec, d, s);
    if (set)
        set(threads);
    return info;
}

static double hg(double g, double mu)
{
    double d = 1.0 + g * g - 2.0 * g * mu;
    return (1.0 - g * g) / (4.0 * VDBS_PI * d * sqrt(d));
}

/* The quadrature matrix p(w_i . w_j) 4 pi / D of an HG of anisotropy g; returns the largest
 * |row sum - 1|. */
static double quadrature(const vdbs_phasemat *m, double g, double *p)
{
    const int d = m->d;
    const double w = 4.0 * VDBS_PI / d;
    double worst = 0.0;
    for (int i = 0; i < d; ++i) {
        double sum = 0.0;
        for (int j = 0; j < d; ++j) {
            const double *a = m->dirs + 3 * i, *b = m->dirs + 3 * j;
            double mu = fmin(1.0, fmax(-1.0, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]));
            p[(size_t)i * d + j] = hg(g, mu) * w;
            sum += p[(size_t)i * d + j];
        }
        worst = fmax(worst, fabs(sum - 1.0));
    }
    return worst;
}

/* Symmetric Sinkhorn balance: s with sum_j s_i P_ij s_j = 1 for every i (the update
 * s_i <- sqrt(s_i / (P s)_i) converges for a positive symmetric matrix), then P <- S P S. */
static void balance(int d, double *p, double *s, double *ps)
{
    for (int i = 0; i < d; ++i)
        s[i] = 1.0;
    for (int sweep = 0; sweep < PHASEMAT_BALANCE_SWEEPS; ++sweep) {
        double worst = 0.0;
        for (int i = 0; i < d; ++i) {
            double sum = 0.0;
            for (int j = 0; j < d; ++j)
                sum += p[(size_t)i * d + j] * s[j];
            ps[i] = sum;
            worst = fmax(worst, fabs(s[i] * sum - 1.0));
        }
        if (worst < PHASEMAT_BALANCE_TOLERANCE)
            break;
        for (int i = 0; i < d; ++i)
            s[i] = sqrt(s[i] / ps[i]);
    }
    for (int i = 0; i < d; ++i)
        for (int j = 0; j < d; ++j)
            p[(size_t)i * d + j] *= s[i] * s[j];
}

static int by_magnitude(const void *a, const void *b)
{
    const double x = fabs(((const double *)a)[0]), y = fabs(((const double *)b)[0]);
    return (x < y) - (x > y);
}

vdbs_status vdbs_phasemat_build(const vdbs_phasemat_desc *desc, vdbs_phasemat *m, vdbs_error *err)
{
    memset(m, 0, sizeof *m);
    const int d = desc->directions;
    const double g = desc->g;
    if (d < 2 || d > VDBS_PHASEMAT_MAX_DIRECTIONS)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--directions %d is not in 2..%d", d,
                              VDBS_PHASEMAT_MAX_DIRECTIONS);
    if (!(g > -1.0 && g < 1.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--g %g is not in (-1, 1)", g);
    m->d = d;
    m->g = g;
    const size_t n = (size_t)d * d;
    m->dirs = malloc(sizeof *m->dirs * 3 * (size_t)d);
    m->p = malloc(sizeof *m->p * n);
    m->eigval = malloc(sizeof *m->eigval * (size_t)d);
    m->eigvec = malloc(sizeof *m->eigvec * n);
    double *s = malloc(sizeof *s * 2 * (size_t)d), *pairs = malloc(sizeof *pairs * 2 * (size_t)d);
    double *vec = malloc(sizeof *vec * n);
    vdbs_status st = VDBS_OK;
    if (!m->dirs || !m->p || !m->eigval || !m->eigvec || !s || !pairs || !vec) {
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a %d x %d phase matrix", d, d);
        goto done;
    }
    vdbs_sphere_directions(d, m->dirs);
    m->quadrature_error = quadrature(m, g, m->p);
    m->g_scaled = g;
    const int use_delta_m =
        desc->delta_m > 0 ||
        (desc->delta_m == 0 && m->quadrature_error > VDBS_PHASEMAT_DELTA_M_TOLERANCE);
    if (use_delta_m && g != 0.0) {
        /* M = floor(sqrt(D)) Legendre moments are what D directions resolve; the truncated
         * phase's moments (g^l - f) / (1 - f) are those of an HG of g* for l = 1. */
        const int moments = (int)floor(sqrt((double)d));
        m->f = g > 0.0 ? pow(g, moments) : 0.0;
        m->g_scaled = (g - m->f) / (1.0 - m->f);
        quadrature(m, m->g_scaled, m->p);
    }
    balance(d, m->p, s, s + d);
    /* dsyevd overwrites its input with the eigenvectors (columns, row-major here). */
    memcpy(vec, m->p, sizeof *vec * n);
    lapack_int info = eigensolve(d, vec, s);
    if (info != 0) {
        st = vdbs_error_set(err, VDBS_ERR_INTERNAL, "the phase matrix's eigensolve failed (%d)",
                            (int)info);
        goto done;
    }
    for (int k = 0; k < d; ++k) {
        pairs[2 * k] = s[k];
        pairs[2 * k + 1] = k;
    }
    qsort(pairs, (size_t)d, 2 * sizeof *pairs, by_magnitude);
    for (int k = 0; k < d; ++k) {
        const int from = (int)pairs[2 * k + 1];
        m->eigval[k] = pairs[2 * k];
        for (int i = 0; i < d; ++i)
            m->eigvec[(size_t)i * d + k] = vec[(size_t)i * d + from];
    }
done:
    free(s);
    free(pairs);
    free(vec);
    if (st != VDBS_OK)
        vdbs_phasemat_free(m);
    return st;
}

void vdbs_phasemat_free(vdbs_phasemat *m)
{
    free(m->dirs);
    free(m->p);
    free(m->eigval);
    free(m->eigvec);
    memset(m, 0, sizeof *m);
}

double vdbs_phasemat_rmse(const vdbs_phasemat *m, int terms)
{
    /* Summed from the smallest |lambda| up, so the dropped part keeps its precision. */
    double dropped = 0.0, all = 0.0;
    for (int k = m->d - 1; k >= 0; --k) {
        const double l2 = m->eigval[k] * m->eigval[k];
        all += l2;
        if (k >= terms)
            dropped += l2;
    }
    return all > 0.0 ? sqrt(dropped / all) : 0.0;
}

double vdbs_phasemat_entry(const vdbs_phasemat *m, int terms, int i, int j)
{
    double sum = 0.0;
    for (int k = 0; k < terms && k < m->d; ++k)
        sum += m->eigval[k] * m->eigvec[(size_t)i * m->d + k] * m->eigvec[(size_t)j * m->d + k];
    return sum;
}
