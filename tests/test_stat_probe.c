/* The reference's Monte-Carlo probe of ms and ms_l1 (vdbs_reference_probe) against
 * independent answers computed here in double:
 *   - single scattering of a sun in a homogeneous slab (closed form per direction, one
 *     quadrature over the direction cosine, averaged over the probe ball exactly);
 *   - single scattering of a point light in a homogeneous medium (the radial convolution of
 *     two attenuated 1/r^2 kernels with the renderer's 1/r^2 clamp, via E1);
 *   - the furnace: a non-absorbing box under a uniform sky (a constant colour plus a
 *     uniform environment map) is lit by exactly the sky's radiance L everywhere, so the
 *     scattered light is L minus the unscattered L exp(-tau): ms = L (1 - <T>) and
 *     ms_l1 = -3 g L <w T> / 4 pi, with the box's exact piecewise-cubic optical depths
 *     integrated over directions and the ball; a map lighting only the upper hemisphere
 *     gives the furnace's answer as the sum of a point and its mirror image;
 *   - the second moment ms_t2 in the furnace (the same closed form with w_a w_b), and its
 *     trace, ms, flight by flight;
 *   - symmetry: under a sun travelling straight down a laterally uniform slab ms_l1 points
 *     along the travel direction (all orders, RGB albedo);
 *   - energy: the scattered power escaping an absorbing box, from the difference of two
 *     huge balls' fluence integrals, against the energy tally's absorbed fraction and the
 *     exactly known power that collides at all;
 *   - bit-identical results whatever the thread count, each of many points (overlapping
 *     balls, many grid cells) as when probed alone, defaults, and input errors.
 * Criteria: |estimate - exact| <= max(floor, 4 se), the floor a small relative allowance
 * for the oracle's own known error (finite lateral extent, quadrature). */
#include "testutil.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/sphere.h"
#include "vdbscatter/envmap.h"
#include "vdbscatter/image.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/volume.h"

#define PI 3.14159265358979323846

/* ---- volumes and scenes ---- */

/* A homogeneous box of dims[a] voxels of world size h[a] (density 1 on every voxel),
 * centred on the origin. Its density is the product of three 1D profiles: 1 up to the
 * outermost voxel centres (|u| <= a_k = (dims - 1) h / 2), a linear ramp to 0 one voxel
 * beyond them. */
static void make_box(const int dims[3], const double h[3], vdbs_volume *volume)
{
    size_t n = (size_t)dims[0] * dims[1] * dims[2];
    float *values = malloc(sizeof(float) * n);
    for (size_t i = 0; i < n; ++i)
        values[i] = 1.0f;
    vdbio_transform xf;
    memset(&xf, 0, sizeof xf);
    for (int a = 0; a < 3; ++a) {
        xf.m[a][a] = h[a];
        xf.m[a][3] = -0.5 * (dims[a] - 1) * h[a];
    }
    vdbio_density *density = NULL;
    vdbs_error err;
    if (vdbio_density_from_dense(values, dims, NULL, &xf, "density", &density, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_volume_from_density(density, volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    free(values);
}

static void medium(vdbs_scene *scene, double density_scale, const double albedo[3], double g)
{
    vdbs_scene_init(scene);
    scene->density_scale = density_scale;
    memcpy(scene->albedo, albedo, sizeof scene->albedo);
    scene->g = g;
}

static vdbs_light *add_light(vdbs_scene *scene, vdbs_light_type type, const double v[3],
                             const double color[3])
{
    vdbs_light *l = &scene->lights[scene->light_count++];
    memset(l, 0, sizeof *l);
    l->type = type;
    if (type == VDBS_LIGHT_SUN)
        memcpy(l->direction, v, sizeof l->direction);
    else if (type == VDBS_LIGHT_POINT)
        memcpy(l->position, v, sizeof l->position);
    memcpy(l->color, color, sizeof l->color);
    l->env_scale = 1.0;
    return l;
}

/* The probe's outputs for up to 8 points. */
typedef struct probe_out {
    double ms[3 * 8], ms_l1[9 * 8], ms_t2[18 * 8], ms_se[3 * 8], ms_l1_se[9 * 8], ms_t2_se[18 * 8];
    double seconds;
} probe_out;

static void run_probe(const vdbs_volume *volume, const vdbs_scene *scene, int64_t photons,
                      double radius, int max_bounces, uint64_t seed, const double *points, size_t n,
                      probe_out *out)
{
    assert_true(n <= 8);
    memset(out, 0, sizeof *out); /* the entries past n stay 0 */
    vdbs_reference_probe_options o = {0};
    o.photons = photons;
    o.radius = radius;
    o.max_bounces = max_bounces;
    o.seed = seed;
    vdbs_error err;
    double t0 = omp_get_wtime();
    const vdbs_reference_probe_outputs to = {out->ms,    out->ms_l1,    out->ms_t2,
                                             out->ms_se, out->ms_l1_se, out->ms_t2_se};
    if (vdbs_reference_probe_moments(volume, scene, &o, points, n, &to, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    out->seconds = omp_get_wtime() - t0;
}

static int failures;

/* |est - exact| <= max(floor, 4 se); prints every comparison. */
static void check(const char *what, double est, double se, double exact, double allow)
{
    double tol = fmax(allow, 4.0 * se);
    int ok = fabs(est - exact) <= tol && isfinite(est) && se >= 0.0;
    print_message("  %-30s %12.6g +- %-10.3g exact %12.6g  z %6.2f  %s\n", what, est, se, exact,
                  se > 0.0 ? (est - exact) / se : 0.0, ok ? "ok" : "FAIL");
    if (!ok)
        ++failures;
}

/* ---- quadrature ---- */

static double hg(double g, double mu)
{
    double d = 1.0 + g * g - 2.0 * g * mu;
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}

/* The average over a ball of radius r centred at height yc of f(y) (a function of height
 * only): (3 / 4 r^3) integral (r^2 - z^2) f(yc + z) dz. */
static double ball_average_y(double (*f)(double y, const void *ctx), const void *ctx, double yc,
                             double r)
{
    double x[24], w[24], s = 0.0;
    test_gauss_legendre(24, -r, r, x, w);
    for (int i = 0; i < 24; ++i)
        s += w[i] * (r * r - x[i] * x[i]) * f(yc + x[i], ctx);
    return 0.75 * s / (r * r * r);
}

/* ---- single scattering of a sun in a slab ----
 *
 * A sun of irradiance E travelling down (-y) into a homogeneous slab of optical thickness
 * tau0 and albedo a. In optical depth tau from the lit face, light that scattered once at
 * depth t and travels along a direction whose cosine to the vertical is m in absolute value
 * has radiance a E p(cos to the sun) exp(-t) exp(-|tau - t| / m) per dt / m; integrating t
 * in closed form leaves, for light travelling down (scattered above, cos = m) and up
 * (scattered below, cos = -m),
 *   Fd(m) = exp(-tau) (1 - exp(-tau (1 - m) / m)) / (1 - m),
 *   Fu(m) = exp(-tau) (1 - exp(-(tau0 - tau) (1 + m) / m)) / (1 + m),
 * and phi_1 = 2 pi a E int_0^1 [p(m) Fd + p(-m) Fu] dm, J_y = 2 pi a E int_0^1 m [-p(m) Fd +
 * p(-m) Fu] dm (J_x = J_z = 0). In optical depth the voxelised slab (the half-voxel ramps
 * included) is exactly this slab, and inside the ramps' reach tau is linear in height. */
typedef struct slab1 {
    double tau0, sigma, top, g, want_flux; /* top: height where tau(y) = sigma (top - y) */
} slab1;

static double slab1_at(double y, const void *ctx)
{
    const slab1 *s = ctx;
    const double tau = s->sigma * (s->top - y);
    enum { PANELS = 400, NODES = 8 };
    double x[NODES], w[NODES], sum = 0.0;
    for (int k = 0; k < PANELS; ++k) {
        test_gauss_legendre(NODES, (double)k / PANELS, (k + 1.0) / PANELS, x, w);
        for (int i = 0; i < NODES; ++i) {
            double m = x[i];
            double fd = exp(-tau) * -expm1(-tau * (1.0 - m) / m) / (1.0 - m);
            double fu = exp(-tau) * -expm1(-(s->tau0 - tau) * (1.0 + m) / m) / (1.0 + m);
            double pd = hg(s->g, m), pu = hg(s->g, -m);
            sum += w[i] * (s->want_flux ? m * (-pd * fd + pu * fu) : pd * fd + pu * fu);
        }
    }
    return 2.0 * PI * sum;
}

/* The slab: 1 world unit thick (32 voxels), 4 wide (16 voxels of 0.25) along x and z. */
static void make_slab(vdbs_volume *volume)
{
    const int dims[3] = {16, 32, 16};
    const double h[3] = {0.25, 1.0 / 32.0, 0.25};
    make_box(dims, h, volume);
}

static void test_sun_single(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_slab(&volume);
    const double sigma = 4.0, g = 0.6, albedo[3] = {0.9, 0.6, 0.3}, e[3] = {1.0, 2.0, 0.5};
    const double down[3] = {0.0, -1.0, 0.0};
    vdbs_scene scene;
    medium(&scene, sigma, albedo, g);
    add_light(&scene, VDBS_LIGHT_SUN, down, e);
    /* Balls inside the slab's constant core (|y| <= 0.5 - 1/64), where tau = sigma (0.5 -
     * y); the lateral half-width of 2 is 8 optical depths. */
    const double r = 0.25, pts[3 * 3] = {0.0, 0.2, 0.0, 0.3, 0.0, -0.2, -0.1, -0.2, 0.1};
    probe_out p;
    run_probe(&volume, &scene, 8000000, r, 1, 7, pts, 3, &p);
    print_message("sun, single scattering, slab tau %g, g %g: %.2fs\n", sigma, g, p.seconds);
    failures = 0;
    for (int i = 0; i < 3; ++i) {
        slab1 s = {sigma, sigma, 0.5, g, 0};
        double phi = ball_average_y(slab1_at, &s, pts[3 * i + 1], r);
        s.want_flux = 1;
        double jy = ball_average_y(slab1_at, &s, pts[3 * i + 1], r);
        for (int c = 0; c < 3; ++c) {
            char what[64];
            double scale = albedo[c] * e[c];
            snprintf(what, sizeof what, "y %+.1f ms[%d]", pts[3 * i + 1], c);
            check(what, p.ms[3 * i + c], p.ms_se[3 * i + c], scale * phi / (4.0 * PI),
                  2e-3 * scale * phi / (4.0 * PI));
            double l1 = 3.0 * g * scale * jy / (4.0 * PI);
            for (int a = 0; a < 3; ++a) {
                snprintf(what, sizeof what, "y %+.1f ms_l1%c[%d]", pts[3 * i + 1], "xyz"[a], c);
                check(what, p.ms_l1[9 * i + 3 * a + c], p.ms_l1_se[9 * i + 3 * a + c],
                      a == 1 ? l1 : 0.0, 2e-3 * fabs(l1));
            }
        }
    }
    vdbs_volume_free(&volume);
    assert_int_equal(failures, 0);
}

/* ---- single scattering of a point light ----
 *
 * A point light of intensity I in a homogeneous medium (sigma, albedo a, isotropic
 * scattering) large enough to be infinite: the unscattered fluence is
 * I exp(-sigma s) / max(s, rc)^2 (the renderer's clamp at rc, half a voxel), and the
 * once-scattered fluence at distance r from the light is
 *   phi_1(r) = a sigma I (1 / 2 r) int_0^inf s exp(-sigma s) / max(s, rc)^2
 *                                   [E1(sigma |r - s|) - E1(sigma (r + s))] ds
 * (the convolution of two radial kernels: 2 pi / r int ds s f(s) int_{|r-s|}^{r+s} t g(t)
 * dt). Its average over a ball of radius rb at distance d: (1 / V) int phi_1(s)
 * pi s (rb^2 - (s - d)^2) / d ds. */
static double expint1(double x)
{
    if (x <= 1.0) {
        double sum = -0.57721566490153286061 - log(x), term = 1.0;
        for (int k = 1; k < 60; ++k) {
            term *= -x / k;
            sum -= term / k;
            if (fabs(term / k) < 1e-17 * fabs(sum))
                break;
        }
        return sum;
    }
    /* Continued fraction (modified Lentz). */
    double b = x + 1.0, c = 1e300, d = 1.0 / b, h = d;
    for (int i = 1; i < 300; ++i) {
        double an = -(double)i * i;
        b += 2.0;
        d = 1.0 / (an * d + b);
        c = b + an / c;
        double del = c * d;
        h *= del;
        if (fabs(del - 1.0) < 1e-16)
            break;
    }
    return h * exp(-x);
}

typedef struct point1 {
    double sigma, rc;
} point1;

static double point1_kernel(const point1 *p, double r, double s)
{
    double m = fmax(s, p->rc);
    return s * exp(-p->sigma * s) / (m * m) *
           (expint1(p->sigma * fabs(r - s)) - expint1(p->sigma * (r + s)));
}

/* phi_1(r) / (a sigma I), for r > rc. */
static double point1_phi(const point1 *p, double r)
{
    enum { PANELS = 24, NODES = 8 };
    double x[NODES], w[NODES], sum = 0.0;
    /* [0, rc]: smooth. */
    test_gauss_legendre(NODES, 0.0, p->rc, x, w);
    for (int i = 0; i < NODES; ++i)
        sum += w[i] * point1_kernel(p, r, x[i]);
    /* [rc, r) and (r, r + V^2]: s = r -+ v^2 tames the logarithm at s = r. */
    double vmax[2] = {sqrt(r - p->rc), sqrt(40.0 / p->sigma)};
    for (int side = 0; side < 2; ++side)
        for (int k = 0; k < PANELS; ++k) {
            test_gauss_legendre(NODES, vmax[side] * k / PANELS, vmax[side] * (k + 1.0) / PANELS, x,
                                w);
            for (int i = 0; i < NODES; ++i) {
                double v = x[i], s = side == 0 ? r - v * v : r + v * v;
                sum += w[i] * 2.0 * v * point1_kernel(p, r, s);
            }
        }
    return sum / (2.0 * r);
}

static double point1_ball(const point1 *p, double d, double rb)
{
    enum { NODES = 32 };
    double x[NODES], w[NODES], sum = 0.0;
    test_gauss_legendre(NODES, d - rb, d + rb, x, w);
    for (int i = 0; i < NODES; ++i) {
        double s = x[i];
        sum += w[i] * point1_phi(p, s) * PI * s * (rb * rb - (s - d) * (s - d)) / d;
    }
    return sum / (4.0 / 3.0 * PI * rb * rb * rb);
}

static void test_point_single(void **state)
{
    (void)state;
    /* A cube of side 16 (32 voxels of 0.5): 8 optical depths from the light to every side. */
    const int dims[3] = {32, 32, 32};
    const double h[3] = {0.5, 0.5, 0.5};
    vdbs_volume volume;
    make_box(dims, h, &volume);
    const double sigma = 1.0, albedo[3] = {0.7, 0.5, 0.2}, intensity[3] = {1.0, 0.5, 2.0};
    const double at[3] = {0.1, 0.2, -0.05};
    vdbs_scene scene;
    medium(&scene, sigma, albedo, 0.0);
    add_light(&scene, VDBS_LIGHT_POINT, at, intensity);
    const double r = 0.3, offs[3][3] = {{1.0, 0.0, 0.0}, {0.0, -0.6, 0.8}, {0.0, 2.0, 0.0}};
    double pts[9];
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a)
            pts[3 * i + a] = at[a] + offs[i][a];
    probe_out p;
    run_probe(&volume, &scene, 5000000, r, 1, 3, pts, 3, &p);
    print_message("point light, single scattering, sigma %g: %.2fs\n", sigma, p.seconds);
    const point1 model = {sigma, 0.5 * volume.mean_voxel_size};
    failures = 0;
    for (int i = 0; i < 3; ++i) {
        double d =
            sqrt(offs[i][0] * offs[i][0] + offs[i][1] * offs[i][1] + offs[i][2] * offs[i][2]);
        double phi = point1_ball(&model, d, r);
        for (int c = 0; c < 3; ++c) {
            char what[64];
            double exact = albedo[c] * sigma * intensity[c] * phi / (4.0 * PI);
            snprintf(what, sizeof what, "d %.1f ms[%d]", d, c);
            /* Floor: the medium's finite extent (exp(-8) of the light) and quadrature. */
            check(what, p.ms[3 * i + c], p.ms_se[3 * i + c], exact, 2e-3 * exact);
            for (int a = 0; a < 3; ++a)
                assert_true(p.ms_l1[9 * i + 3 * a + c] == 0.0); /* g = 0 */
        }
    }
    vdbs_volume_free(&volume);
    assert_int_equal(failures, 0);
}

/* ---- the furnace ----
 *
 * A non-absorbing medium under a sky of uniform radiance L carries L in every direction
 * everywhere (L solves the transfer equation when sigma_s = sigma_t), whatever the
 * density, g or shape. The light that has scattered is L minus the unscattered
 * L exp(-tau(x, w)), tau the optical depth from x back to the sky against the travel
 * direction w. So over the ball ms = L (1 - <T>), <T> = ball average of (1 / 4 pi) int T dw,
 * and ms_l1 = 3 g (-L <int w T dw>) / 4 pi. The box's density is r(x) r(y) r(z) with r the
 * 1D profile of make_box: along a ray it is a cubic between the crossings of the profiles'
 * corners, integrated exactly by 2-point Gauss-Legendre. */
typedef struct box_profile {
    double core[3], ramp[3]; /* r = 1 for |u| <= core, ramps to 0 at core + ramp */
    double sigma;
} box_profile;

static double profile(const box_profile *b, int a, double u)
{
    double d = fabs(u) - b->core[a];
    return d <= 0.0 ? 1.0 : d >= b->ramp[a] ? 0.0 : 1.0 - d / b->ramp[a];
}

static double box_density(const box_profile *b, const double x[3])
{
    return profile(b, 0, x[0]) * profile(b, 1, x[1]) * profile(b, 2, x[2]);
}

/* Optical depth from x along the unit direction v to infinity. */
static double box_tau(const box_profile *b, const double x[3], const double v[3])
{
    double t[16];
    int n = 0;
    double t_end = HUGE_VAL;
    t[n++] = 0.0;
    for (int a = 0; a < 3; ++a) {
        if (v[a] == 0.0)
            continue;
        const double edges[4] = {-b->core[a] - b->ramp[a], -b->core[a], b->core[a],
                                 b->core[a] + b->ramp[a]};
        for (int k = 0; k < 4; ++k) {
            double tk = (edges[k] - x[a]) / v[a];
            if (tk > 0.0)
                t[n++] = tk;
        }
        t_end = fmin(t_end, fmax((edges[0] - x[a]) / v[a], (edges[3] - x[a]) / v[a]));
    }
    qsort(t, (size_t)n, sizeof *t, test_compare_doubles);
    double sum = 0.0;
    const double q = 0.5 / sqrt(3.0);
    for (int k = 0; k + 1 < n && t[k] < t_end; ++k) {
        double ta = t[k], tb = fmin(t[k + 1], t_end), mid = 0.5 * (ta + tb), half = tb - ta;
        for (int s = -1; s <= 1; s += 2) {
            double tt = mid + s * q * half, p[3];
            for (int a = 0; a < 3; ++a)
                p[a] = x[a] + tt * v[a];
            sum += 0.5 * half * box_density(b, p);
        }
    }
    return b->sigma * sum;
}

/* <T>, <int w T dw> and <int w_a w_b T dw> (xx, yy, zz, xy, xz, yz; per unit L) over the
 * ball of radius rb at c: the ball by Gauss-Legendre in r^3 (uniform in volume) times a
 * Fibonacci set of directions, the sphere of travel directions w by a Fibonacci set of nd
 * directions. */
static void furnace_exact(const box_profile *b, const double c[3], double rb, double *t_mean,
                          double flux[3], double second[6])
{
    enum { NR = 6, NB = 48, ND = 6000 };
    static double dirs[3 * ND], bdirs[3 * NB];
    vdbs_sphere_directions(ND, dirs);
    vdbs_sphere_directions(NB, bdirs);
    double xr[NR], wr[NR];
    test_gauss_legendre(NR, 0.0, 1.0, xr, wr);
    double tsum = 0.0, fsum[3] = {0.0, 0.0, 0.0}, ssum[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i < NR; ++i) {
        double rad = rb * cbrt(xr[i]);
        for (int j = 0; j < NB; ++j) {
            double x[3];
            for (int a = 0; a < 3; ++a)
                x[a] = c[a] + rad * bdirs[3 * j + a];
            for (int k = 0; k < ND; ++k) {
                const double *w = dirs + 3 * k;
                double back[3] = {-w[0], -w[1], -w[2]};
                double tr = exp(-box_tau(b, x, back)) * wr[i] / NB;
                tsum += tr / ND;
                for (int a = 0; a < 3; ++a)
                    fsum[a] += tr * w[a] * 4.0 * PI / ND;
                const double ww[6] = {w[0] * w[0], w[1] * w[1], w[2] * w[2],
                                      w[0] * w[1], w[0] * w[2], w[1] * w[2]};
                for (int q = 0; q < 6; ++q)
                    ssum[q] += tr * ww[q] * 4.0 * PI / ND;
            }
        }
    }
    *t_mean = tsum;
    memcpy(flux, fsum, sizeof fsum);
    memcpy(second, ssum, sizeof ssum);
}

/* Writes a 2H x H map: rows above the horizon `upper`, below it `lower`. */
static const char *write_map(const char *name, int hgt, const float upper[3], const float lower[3])
{
    vdbs_image image;
    vdbs_error err;
    assert_int_equal(vdbs_image_alloc(&image, 2 * hgt, hgt, 0, &err), VDBS_OK);
    for (int y = 0; y < hgt; ++y)
        for (int x = 0; x < 2 * hgt; ++x)
            memcpy(image.rgb + 3 * ((size_t)y * 2 * hgt + x), y < hgt / 2 ? upper : lower,
                   sizeof(float) * 3);
    const char *path = test_tmp_path(name);
    assert_int_equal(vdbs_image_write(path, &image, 0.0, &err), VDBS_OK);
    vdbs_image_free(&image);
    return path;
}

static void test_furnace(void **state)
{
    (void)state;
    /* A unit cube (16^3 voxels), 3 optical depths across. */
    const int dims[3] = {16, 16, 16};
    const double h[3] = {1.0 / 16, 1.0 / 16, 1.0 / 16};
    vdbs_volume volume;
    make_box(dims, h, &volume);
    const double sigma = 3.0, g = 0.6, one[3] = {1.0, 1.0, 1.0};
    box_profile box;
    box.sigma = sigma;
    for (int a = 0; a < 3; ++a) {
        box.core[a] = 0.5 * (dims[a] - 1) * h[a];
        box.ramp[a] = h[a];
    }
    const double r = 0.25;
    const double pts[3 * 3] = {0.0, 0.0, 0.0, 0.12, 0.15, -0.08, 0.12, -0.15, -0.08};
    double t_mean[3], flux[3][3], second[3][6];
    double t0 = omp_get_wtime();
    for (int i = 0; i < 3; ++i)
        furnace_exact(&box, pts + 3 * i, r, &t_mean[i], flux[i], second[i]);
    print_message("furnace quadrature: %.2fs; <T> %.7f %.7f %.7f, <wT>y %.7f %.7f %.7f\n",
                  omp_get_wtime() - t0, t_mean[0], t_mean[1], t_mean[2], flux[0][1], flux[1][1],
                  flux[2][1]);
    /* The mirror point's answers are the mirror images (to the quadrature's accuracy: its
     * Fibonacci sets are not mirror-symmetric). */
    assert_true(fabs(t_mean[1] - t_mean[2]) < 1e-4 * t_mean[1]);
    assert_true(fabs(flux[1][1] + flux[2][1]) < 1e-3 * fabs(flux[1][1]));

    /* 1: a constant colour plus a uniform map: sky radiance L = (1, 1, 1.5). */
    {
        const float map_rgb[3] = {0.7f, 0.5f, 1.3f};
        const double constant[3] = {0.3, 0.5, 0.2}, L[3] = {1.0, 1.0, 1.5};
        vdbs_scene scene;
        medium(&scene, sigma, one, g);
        add_light(&scene, VDBS_LIGHT_ENV, NULL, constant);
        vdbs_light *l = add_light(&scene, VDBS_LIGHT_ENV, NULL, (const double[3]){0, 0, 0});
        vdbs_error err;
        assert_int_equal(vdbs_light_set_env_file(
                             &scene, l, write_map("probe_uniform.exr", 32, map_rgb, map_rgb), &err),
                         VDBS_OK);
        probe_out p;
        run_probe(&volume, &scene, 4000000, r, 0, 5, pts, 2, &p);
        print_message("furnace, constant + uniform map, g %g: %.2fs\n", g, p.seconds);
        failures = 0;
        for (int i = 0; i < 2; ++i)
            for (int c = 0; c < 3; ++c) {
                char what[64];
                double ms = L[c] * (1.0 - t_mean[i]);
                snprintf(what, sizeof what, "point %d ms[%d]", i, c);
                check(what, p.ms[3 * i + c], p.ms_se[3 * i + c], ms, 2e-3 * ms);
                for (int a = 0; a < 3; ++a) {
                    double l1 = -3.0 * g * L[c] * flux[i][a] / (4.0 * PI);
                    snprintf(what, sizeof what, "point %d ms_l1%c[%d]", i, "xyz"[a], c);
                    check(what, p.ms_l1[9 * i + 3 * a + c], p.ms_l1_se[9 * i + 3 * a + c], l1,
                          2e-3 * ms);
                }
                /* The scattered light is L (1 - T) per direction: its second moment is
                 * L (delta_ab / 3 - <int w_a w_b T dw> / 4 pi). */
                for (int q = 0; q < 6; ++q) {
                    double t2 = L[c] * ((q < 3 ? 1.0 / 3.0 : 0.0) - second[i][q] / (4.0 * PI));
                    snprintf(what, sizeof what, "point %d ms_t2%s[%d]", i,
                             (const char *[]){"xx", "yy", "zz", "xy", "xz", "yz"}[q], c);
                    check(what, p.ms_t2[18 * i + 3 * q + c], p.ms_t2_se[18 * i + 3 * q + c], t2,
                          2e-3 * ms);
                }
            }
        assert_int_equal(failures, 0);
    }

    /* 2: a map lighting only the upper hemisphere (its rows split at the horizon). By the
     * box's mirror symmetry the lower hemisphere gives at x what the upper gives at the
     * mirror image x', so ms(x) + ms(x') is the furnace's ms for L, and likewise ms_l1
     * with the y component of x' flipped. */
    {
        const float up[3] = {1.0f, 0.25f, 2.0f}, dark[3] = {0.0f, 0.0f, 0.0f};
        vdbs_scene scene;
        medium(&scene, sigma, one, g);
        vdbs_light *l = add_light(&scene, VDBS_LIGHT_ENV, NULL, (const double[3]){0, 0, 0});
        vdbs_error err;
        assert_int_equal(
            vdbs_light_set_env_file(&scene, l, write_map("probe_upper.exr", 32, up, dark), &err),
            VDBS_OK);
        probe_out p;
        run_probe(&volume, &scene, 4000000, r, 0, 9, pts + 3, 2, &p);
        print_message("furnace, upper-hemisphere map, g %g: %.2fs\n", g, p.seconds);
        failures = 0;
        for (int c = 0; c < 3; ++c) {
            char what[64];
            double ms = up[c] * (1.0 - t_mean[1]);
            snprintf(what, sizeof what, "x + x' ms[%d]", c);
            check(what, p.ms[c] + p.ms[3 + c], p.ms_se[c] + p.ms_se[3 + c], ms, 2e-3 * ms);
            for (int a = 0; a < 3; ++a) {
                double sign = a == 1 ? -1.0 : 1.0;
                double l1 = -3.0 * g * up[c] * flux[1][a] / (4.0 * PI);
                snprintf(what, sizeof what, "x + x' ms_l1%c[%d]", "xyz"[a], c);
                /* The two points share photons: the sum of the se's bounds the se of the
                 * sum whatever their correlation. */
                check(what, p.ms_l1[3 * a + c] + sign * p.ms_l1[9 + 3 * a + c],
                      p.ms_l1_se[3 * a + c] + p.ms_l1_se[9 + 3 * a + c], l1, 2e-3 * ms);
            }
        }
        assert_int_equal(failures, 0);
    }
    vdbs_volume_free(&volume);
}

/* ---- symmetry under a sun, all orders ---- */

static void test_sun_symmetry(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_slab(&volume);
    const double sigma = 2.0, g = 0.6, albedo[3] = {0.95, 0.8, 0.5}, e[3] = {1.0, 1.0, 1.0};
    const double down[3] = {0.0, -1.0, 0.0};
    vdbs_scene scene;
    medium(&scene, sigma, albedo, g);
    add_light(&scene, VDBS_LIGHT_SUN, down, e);
    /* On the slab's vertical axis, where the box's mirror symmetries in x and z make the
     * lateral flux vanish exactly. */
    const double r = 0.25, pts[3 * 2] = {0.0, 0.2, 0.0, 0.0, -0.2, 0.0};
    probe_out p, p1;
    run_probe(&volume, &scene, 3000000, r, 0, 11, pts, 2, &p);
    run_probe(&volume, &scene, 3000000, r, 1, 11, pts, 2, &p1);
    print_message("sun, all orders, slab tau %g: %.2fs (single: %.2fs)\n", sigma, p.seconds,
                  p1.seconds);
    failures = 0;
    for (int i = 0; i < 2; ++i)
        for (int c = 0; c < 3; ++c) {
            char what[64];
            double lat = 0.0;
            for (int a = 0; a < 3; a += 2) {
                snprintf(what, sizeof what, "y %+.1f ms_l1%c[%d]", pts[3 * i + 1], "xyz"[a], c);
                check(what, p.ms_l1[9 * i + 3 * a + c], p.ms_l1_se[9 * i + 3 * a + c], 0.0, 1e-9);
                lat = fmax(lat, fabs(p.ms_l1[9 * i + 3 * a + c]));
            }
            /* Along the travel direction, by far. */
            double ly = p.ms_l1[9 * i + 3 + c];
            print_message("  y %+.1f [%d]: ms %.5f (single %.5f), ms_l1y %.5f +- %.2g\n",
                          pts[3 * i + 1], c, p.ms[3 * i + c], p1.ms[3 * i + c], ly,
                          p.ms_l1_se[9 * i + 3 + c]);
            if (!(ly < -8.0 * p.ms_l1_se[9 * i + 3 + c] && ly < -20.0 * lat))
                ++failures;
            /* Every order adds light. */
            if (!(p.ms[3 * i + c] >
                  p1.ms[3 * i + c] + 4.0 * (p.ms_se[3 * i + c] + p1.ms_se[3 * i + c])))
                ++failures;
            /* The second moment's trace is ms, flight by flight (|w| = 1); its values are
             * checked against the furnace's closed form above. */
            const double *t2 = p.ms_t2 + 18 * i;
            snprintf(what, sizeof what, "y %+.1f trace ms_t2[%d]", pts[3 * i + 1], c);
            check(what, t2[c] + t2[3 + c] + t2[6 + c], 0.0, p.ms[3 * i + c],
                  1e-12 * p.ms[3 * i + c]);
        }
    vdbs_volume_free(&volume);
    assert_int_equal(failures, 0);
}

/* ---- energy: scattered light leaving a box, against the energy tally ----
 *
 * Light that has scattered and leaves a convex medium never comes back, so for two balls
 * centred on the medium that both hold it, radii R1 < R2, the difference of their fluence
 * integrals V phi counts only the escaping scattered light between the two spheres: a
 * photon leaving from y inside the medium travels sqrt(R2^2 - q^2) - sqrt(R1^2 - q^2)
 * there (q its distance from the centre across the flight, |q| <= |y|), which is R2 - R1
 * within q^2 (1 / R1 - 1 / R2) / 2 (5e-4 relative here). So
 *   P_esc = (V2 phi2 - V1 phi1) / (R2 - R1)
 * is the scattered power that escapes. The energy tally of the same sun (photons through
 * a disc that covers the box) gives the absorbed fraction A, and the power that collides
 * at all, P_col = E integral (1 - exp(-sigma r(x) r(z))) dx dz over the box's shadow (the
 * column through the box has optical depth sigma r(x) r(z), its profile integrating to 1
 * along y), is exact: P_esc = P_col - A E pi Rd^2 in expectation (all collided light is
 * absorbed or escapes after scattering; paths cut by max_bounces count as absorbed in
 * both). The tally follows the red channel (albedo[0]). */
static void test_escape_energy(void **state)
{
    (void)state;
    const int dims[3] = {16, 16, 16};
    const double h[3] = {1.0 / 16, 1.0 / 16, 1.0 / 16};
    vdbs_volume volume;
    make_box(dims, h, &volume);
    const double sigma = 3.0, g = 0.6, albedo[3] = {0.8, 0.5, 0.2}, e[3] = {1.0, 1.0, 1.0};
    const double down[3] = {0.0, -1.0, 0.0}, origin[3] = {0.0, 0.0, 0.0};
    vdbs_scene scene;
    medium(&scene, sigma, albedo, g);
    add_light(&scene, VDBS_LIGHT_SUN, down, e);
    box_profile box;
    box.sigma = sigma;
    for (int a = 0; a < 3; ++a) {
        box.core[a] = 0.5 * (dims[a] - 1) * h[a];
        box.ramp[a] = h[a];
    }
    /* P_col: Gauss-Legendre on the core and the two ramps of each axis. */
    double p_col = 0.0;
    {
        enum { NQ = 16 };
        double xs[3 * NQ], ws[3 * NQ];
        const double c = box.core[0], rr = box.ramp[0];
        test_gauss_legendre(NQ, -c - rr, -c, xs, ws);
        test_gauss_legendre(NQ, -c, c, xs + NQ, ws + NQ);
        test_gauss_legendre(NQ, c, c + rr, xs + 2 * NQ, ws + 2 * NQ);
        for (int i = 0; i < 3 * NQ; ++i)
            for (int j = 0; j < 3 * NQ; ++j)
                p_col += ws[i] * ws[j] *
                         -expm1(-sigma * profile(&box, 0, xs[i]) * profile(&box, 2, xs[j]));
    }
    const double rd = 0.8; /* the tally's disc: covers the box's shadow (half-diagonal 0.75) */
    vdbs_reference_tally tally;
    vdbs_error err;
    double t0 = omp_get_wtime();
    if (vdbs_reference_tally_sun(&volume, &scene, origin, rd, 2000000, 1000, 21, &tally, &err) !=
        VDBS_OK)
        fail_msg("%s", err.message);
    double t_tally = omp_get_wtime() - t0;
    const double area = PI * rd * rd;
    const double esc_tally = p_col - tally.absorbed * area, esc_tally_se = tally.absorbed_se * area;

    const double radii[2] = {20.0, 40.0};
    probe_out p[2];
    for (int k = 0; k < 2; ++k)
        run_probe(&volume, &scene, 3000000, radii[k], 0, 31 + (uint64_t)k, origin, 1, &p[k]);
    double vphi[2][3], vphi_se[2][3];
    for (int k = 0; k < 2; ++k)
        for (int c = 0; c < 3; ++c) {
            double v = 4.0 / 3.0 * PI * pow(radii[k], 3.0) * 4.0 * PI;
            vphi[k][c] = p[k].ms[c] * v;
            vphi_se[k][c] = p[k].ms_se[c] * v;
        }
    const double dr = radii[1] - radii[0];
    double esc = (vphi[1][0] - vphi[0][0]) / dr, esc_se = hypot(vphi_se[1][0], vphi_se[0][0]) / dr;
    print_message("escape: P_col %.6f, tally absorbed %.6f +- %.2g (%.2fs), probe %.2fs + %.2fs\n",
                  p_col, tally.absorbed, tally.absorbed_se, t_tally, p[0].seconds, p[1].seconds);
    failures = 0;
    /* The two estimates are independent: 4 se of their difference, and the allowance for
     * the spheres' curvature. */
    check("escaping scattered power [0]", esc, hypot(esc_se, esc_tally_se), esc_tally,
          1e-3 * esc_tally);
    for (int c = 1; c < 3; ++c)
        print_message("  escaping scattered power [%d]: %.6f +- %.2g\n", c,
                      (vphi[1][c] - vphi[0][c]) / dr, hypot(vphi_se[1][c], vphi_se[0][c]) / dr);
    vdbs_volume_free(&volume);
    assert_int_equal(failures, 0);
}

/* ---- determinism, defaults, errors ---- */

static void test_threads_and_errors(void **state)
{
    (void)state;
    vdbs_volume volume;
    test_sample_volume("cloud", 24, 1, &volume);
    const double albedo[3] = {0.9, 0.8, 0.7}, dir[3] = {0.3, -1.0, 0.2}, e[3] = {3.0, 3.0, 3.0};
    const double pos[3] = {0.5, 1.2, -0.3}, in[3] = {1.0, 0.5, 0.2}, sky[3] = {0.1, 0.2, 0.4};
    vdbs_scene scene;
    medium(&scene, 8.0, albedo, 0.5);
    add_light(&scene, VDBS_LIGHT_SUN, dir, e);
    add_light(&scene, VDBS_LIGHT_POINT, pos, in);
    add_light(&scene, VDBS_LIGHT_ENV, NULL, sky);
    const double pts[3 * 4] = {0.0, 0.0, 0.0, 0.2, 0.3, -0.1, -0.4, 0.1, 0.2, 5.0, 5.0, 5.0};
    probe_out a, b;
    int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    run_probe(&volume, &scene, 20000, 0.0, 0, 42, pts, 4, &a);
    omp_set_num_threads(2);
    run_probe(&volume, &scene, 20000, 0.0, 0, 42, pts, 4, &b);
    omp_set_num_threads(threads);
    assert_memory_equal(a.ms, b.ms, sizeof a.ms);
    assert_memory_equal(a.ms_l1, b.ms_l1, sizeof a.ms_l1);
    assert_memory_equal(a.ms_se, b.ms_se, sizeof a.ms_se);
    assert_memory_equal(a.ms_l1_se, b.ms_l1_se, sizeof a.ms_l1_se);
    for (int i = 0; i < 3; ++i)
        for (int c = 0; c < 3; ++c) {
            assert_true(a.ms[3 * i + c] > 0.0 && isfinite(a.ms[3 * i + c]));
            assert_true(a.ms_se[3 * i + c] > 0.0 && a.ms_se[3 * i + c] < a.ms[3 * i + c]);
        }
    /* Outside the volume scattered light still passes (a fluence, not a source). */
    for (int c = 0; c < 3; ++c)
        assert_true(a.ms[9 + c] >= 0.0 && isfinite(a.ms[9 + c]));

    /* Many points (the ball grid has many cells, balls overlap): each point's results are
     * those of the point probed alone, bit for bit (same photons, same order of sums). */
    {
        enum { MANY = 300 };
        double *many = malloc(sizeof(double) * 3 * MANY), *mms = malloc(sizeof(double) * 3 * MANY);
        double *ml1 = malloc(sizeof(double) * 9 * MANY), *mse = malloc(sizeof(double) * 9 * MANY);
        uint64_t x = 12345;
        for (int i = 0; i < 3 * MANY; ++i) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            many[i] = 2.4 * ((double)(x >> 11) * 0x1.0p-53) - 1.2;
        }
        vdbs_reference_probe_options o = {0};
        o.photons = 20000;
        o.seed = 5;
        vdbs_error err;
        assert_int_equal(
            vdbs_reference_probe(&volume, &scene, &o, many, MANY, mms, ml1, NULL, mse, &err),
            VDBS_OK);
        int nonzero = 0;
        for (int i = 0; i < MANY; i += 37) {
            double ms1[3], l11[9], se1[9];
            assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, many + 3 * i, 1, ms1, l11,
                                                  NULL, se1, &err),
                             VDBS_OK);
            assert_memory_equal(ms1, mms + 3 * i, sizeof ms1);
            assert_memory_equal(l11, ml1 + 9 * i, sizeof l11);
            assert_memory_equal(se1, mse + 9 * i, sizeof se1);
            nonzero += ms1[0] > 0.0;
        }
        assert_true(nonzero >= 5);
        free(many);
        free(mms);
        free(ml1);
        free(mse);
    }

    /* Options NULL: the defaults; outputs may be NULL. */
    vdbs_error err;
    double ms[3];
    vdbs_scene sun_only;
    medium(&sun_only, 8.0, albedo, 0.0);
    add_light(&sun_only, VDBS_LIGHT_SUN, dir, e);
    assert_int_equal(
        vdbs_reference_probe(&volume, &sun_only, NULL, pts, 1, ms, NULL, NULL, NULL, &err),
        VDBS_OK);
    assert_true(ms[0] > 0.0);
    /* A scene without light: zeros. */
    vdbs_scene dark;
    medium(&dark, 8.0, albedo, 0.5);
    ms[0] = 1.0;
    assert_int_equal(vdbs_reference_probe(&volume, &dark, NULL, pts, 1, ms, NULL, NULL, NULL, &err),
                     VDBS_OK);
    assert_true(ms[0] == 0.0 && ms[1] == 0.0 && ms[2] == 0.0);
    /* No points. */
    assert_int_equal(
        vdbs_reference_probe(&volume, &scene, NULL, NULL, 0, NULL, NULL, NULL, NULL, &err),
        VDBS_OK);

    vdbs_reference_probe_options o = {0};
    o.radius = -1.0;
    assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, pts, 1, ms, NULL, NULL, NULL, &err),
                     VDBS_ERR_INPUT);
    print_message("error: %s\n", err.message);
    o.radius = NAN;
    assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, pts, 1, ms, NULL, NULL, NULL, &err),
                     VDBS_ERR_INPUT);
    o.radius = 0.0;
    o.photons = -5;
    assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, pts, 1, ms, NULL, NULL, NULL, &err),
                     VDBS_ERR_INPUT);
    o.photons = 0;
    o.max_bounces = -1;
    assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, pts, 1, ms, NULL, NULL, NULL, &err),
                     VDBS_ERR_INPUT);
    o.max_bounces = 0;
    const double bad[3] = {0.0, INFINITY, 0.0};
    assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, bad, 1, ms, NULL, NULL, NULL, &err),
                     VDBS_ERR_INPUT);
    print_message("error: %s\n", err.message);
    assert_int_equal(vdbs_reference_probe(&volume, &scene, &o, NULL, 2, ms, NULL, NULL, NULL, &err),
                     VDBS_ERR_INPUT);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sun_single),    cmocka_unit_test(test_point_single),
        cmocka_unit_test(test_furnace),       cmocka_unit_test(test_sun_symmetry),
        cmocka_unit_test(test_escape_energy), cmocka_unit_test(test_threads_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
