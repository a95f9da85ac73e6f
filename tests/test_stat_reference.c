/* The Monte-Carlo reference against independent answers: reflected and transmitted
 * fractions of homogeneous slabs (energy tally) and the radiance leaving them (rendered,
 * single and all orders) against an adding-doubling solution written here; single
 * scattering of a point light against quadrature; energy conservation in a closed sphere;
 * noise falling as 1/sqrt(spp); bit-identical images whatever the thread count; rounds
 * under a time limit; HG sampling against its CDF; finite, non-negative results at the
 * numerical extremes of docs/design.md. */
#include "planeparallel.h"
#include "testutil.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/envmap.h"
#include "vdbscatter/image.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/render.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/volume.h"

#define PI 3.14159265358979323846

#define NQ PP_NQ

/* ---- volumes and scenes ---- */

static void make_volume(const float *values, const int dims[3], const double m[3][4],
                        vdbs_volume *volume)
{
    vdbio_transform xf;
    memcpy(xf.m, m, sizeof xf.m);
    vdbio_density *density = NULL;
    vdbs_error err;
    if (vdbio_density_from_dense(values, dims, NULL, &xf, "density", &density, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_volume_from_density(density, volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* A slab n voxels thick along y (voxel height 1/n, so its optical thickness is exactly
 * density_scale including the two half-voxel ramps) and w voxels of size 1 across, 64
 * times wider than it is thick, centred on the origin. */
static void make_slab(int n, int w, vdbs_volume *volume)
{
    float *values = malloc(sizeof(float) * (size_t)w * n * w);
    for (size_t i = 0; i < (size_t)w * n * w; ++i)
        values[i] = 1.0f;
    int dims[3] = {w, n, w};
    double m[3][4] = {{1.0, 0.0, 0.0, -0.5 * (w - 1)},
                      {0.0, 1.0 / n, 0.0, -0.5 * (n - 1) / n},
                      {0.0, 0.0, 1.0, -0.5 * (w - 1)}};
    make_volume(values, dims, m, volume);
    free(values);
}

static void make_sample(const char *name, int res, vdbs_volume *volume)
{
    vdbio_density *density = NULL;
    vdbs_error err;
    if (vdbs_sample_create(name, res, 1, &density, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_volume_from_density(density, volume, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

static void medium(vdbs_scene *scene, double density_scale, double albedo, double g)
{
    vdbs_scene_init(scene);
    scene->density_scale = density_scale;
    scene->albedo[0] = scene->albedo[1] = scene->albedo[2] = albedo;
    scene->g = g;
}

static void add_sun(vdbs_scene *scene, double x, double y, double z, double e)
{
    vdbs_light *l = &scene->lights[scene->light_count++];
    memset(l, 0, sizeof *l);
    l->type = VDBS_LIGHT_SUN;
    double len = sqrt(x * x + y * y + z * z);
    l->direction[0] = x / len;
    l->direction[1] = y / len;
    l->direction[2] = z / len;
    l->color[0] = l->color[1] = l->color[2] = e;
}

static void add_point(vdbs_scene *scene, double x, double y, double z, double intensity)
{
    vdbs_light *l = &scene->lights[scene->light_count++];
    memset(l, 0, sizeof *l);
    l->type = VDBS_LIGHT_POINT;
    l->position[0] = x;
    l->position[1] = y;
    l->position[2] = z;
    l->color[0] = l->color[1] = l->color[2] = intensity;
}

static void add_env(vdbs_scene *scene, double r, double g, double b)
{
    vdbs_light *l = &scene->lights[scene->light_count++];
    memset(l, 0, sizeof *l);
    l->type = VDBS_LIGHT_ENV;
    l->color[0] = r;
    l->color[1] = g;
    l->color[2] = b;
    l->env_scale = 1.0;
}

static void image_make(vdbs_image *image, int width, int height)
{
    vdbs_error err;
    if (vdbs_image_alloc(image, width, height, 1, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

static void image_drop(vdbs_image *image)
{
    vdbs_image_free(image);
}

static void render_camera(const vdbs_volume *volume, const vdbs_scene *scene,
                          const vdbs_camera *camera, int spp, int max_bounces, uint64_t seed,
                          vdbs_image *image)
{
    vdbs_camera_frame frame;
    vdbs_error err;
    assert_int_equal(vdbs_camera_frame_init(camera, &frame, &err), VDBS_OK);
    image_make(image, camera->width, camera->height);
    vdbs_reference_options options = {0};
    options.spp = spp;
    options.max_bounces = max_bounces;
    options.seed = seed;
    if (vdbs_reference_render(volume, scene, &frame, &options, image, NULL, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

static void render(const vdbs_volume *volume, const vdbs_scene *scene, int size, int spp,
                   int max_bounces, uint64_t seed, vdbs_image *image)
{
    vdbs_camera camera;
    vdbs_camera_frame_volume(volume, size, size, &camera);
    vdbs_camera_frame frame;
    vdbs_error err;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    image_make(image, size, size);
    vdbs_reference_options options = {0};
    options.spp = spp;
    options.max_bounces = max_bounces;
    options.seed = seed;
    int done = 0;
    if (vdbs_reference_render(volume, scene, &frame, &options, image, &done, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(done, spp);
}

/* ---- tests ---- */

static void test_slab(void **state)
{
    (void)state;
    const int n = 16, w = 64;
    vdbs_volume volume;
    make_slab(n, w, &volume);
    const double taus[] = {1.0, 4.0}, albedos[] = {0.5, 0.99}, gs[] = {0.0, 0.9};
    const double centre[3] = {0.0, 0.0, 0.0};
    uint64_t seed = 11;
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int c = 0; c < 2; ++c) {
                double tau = taus[a], albedo = albedos[b], g = gs[c];
                double r_ad, t_ad;
                pp_adding_doubling(tau, albedo, g, &r_ad, &t_ad, NULL, NULL);
                vdbs_scene scene;
                medium(&scene, tau, albedo, g);
                add_sun(&scene, 0.0, -1.0, 0.0, 1.0);
                vdbs_reference_tally tally;
                vdbs_error err;
                const int64_t paths = 2000000;
                double t0 = omp_get_wtime();
                if (vdbs_reference_tally_sun(&volume, &scene, centre, 0.5, paths, 100000, seed++,
                                             &tally, &err) != VDBS_OK)
                    fail_msg("%s", err.message);
                double dt = omp_get_wtime() - t0;
                print_message("slab tau %g albedo %g g %g: R %.5f +- %.5f (AD %.5f)  T %.5f +- "
                              "%.5f (AD %.5f)  A %.5f  side %.2e  %.2fs\n",
                              tau, albedo, g, tally.reflected, tally.reflected_se, r_ad,
                              tally.transmitted, tally.transmitted_se, t_ad, tally.absorbed,
                              tally.side_leak, dt);
                assert_true(tally.side_leak < 1e-3);
                double tol_r = fmax(0.01 * r_ad, 4.0 * tally.reflected_se);
                double tol_t = fmax(0.01 * t_ad, 4.0 * tally.transmitted_se);
                if (fabs(tally.reflected - r_ad) > tol_r || fabs(tally.transmitted - t_ad) > tol_t)
                    fail_msg("slab tau %g albedo %g g %g: R %.6f T %.6f, adding-doubling R %.6f "
                             "T %.6f",
                             tau, albedo, g, tally.reflected, tally.transmitted, r_ad, t_ad);
            }
    vdbs_volume_free(&volume);
}

/* Mean of channel 0 over the image and its standard error (pixels are independent). */
static void image_mean(const vdbs_image *image, double *mean, double *se)
{
    int n = image->width * image->height;
    double m = 0.0, v = 0.0;
    for (int i = 0; i < n; ++i) {
        m += image->rgb[3 * i];
        v += (double)image->se[3 * i] * image->se[3 * i];
    }
    *mean = m / n;
    *se = sqrt(v) / n;
}

static double hg_phase(double g, double mu)
{
    return pp_hg(g, mu);
}

/* Radiance leaving the slab of test_slab in a direction of cosine mu to its normal,
 * seen by a narrow camera at the slab's centre, against single scattering in closed
 * form (max_bounces 1) and against adding-doubling (all orders): next-event estimation
 * to the sun with ratio-tracked shadow rays, and the bounce limit. */
static void test_slab_radiance(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_slab(16, 64, &volume);
    double mu_q[NQ], w_q[NQ];
    test_gauss_legendre(NQ, 0.0, 1.0, mu_q, w_q);
    int node = 0;
    for (int i = 0; i < NQ; ++i)
        if (fabs(mu_q[i] - 0.7) < fabs(mu_q[node] - 0.7))
            node = i;
    const double mu = mu_q[node], sin_t = sqrt(1.0 - mu * mu);
    const double tau = 1.0, albedo = 0.9, gs[2] = {0.0, 0.9};
    uint64_t seed = 300;
    for (int k = 0; k < 2; ++k) {
        double g = gs[k];
        double r_flux, t_flux, r_rad[NQ], t_rad[NQ];
        pp_adding_doubling(tau, albedo, g, &r_flux, &t_flux, r_rad, t_rad);
        /* Single scattering of a normal beam of irradiance 1 (cosine mu0 = 1). */
        double r1 = albedo * hg_phase(g, -mu) / (1.0 + mu) * -expm1(-tau * (1.0 + 1.0 / mu));
        double t1 = albedo * hg_phase(g, mu) * (exp(-tau) - exp(-tau / mu)) / (1.0 - mu);
        vdbs_scene scene;
        medium(&scene, tau, albedo, g);
        add_sun(&scene, 0.0, -1.0, 0.0, 1.0);
        for (int side = 0; side < 2; ++side) {
            /* Above: looking down at the lit face; below: looking up at the far face. */
            double sy = side == 0 ? 1.0 : -1.0;
            vdbs_camera camera = {0};
            camera.present = 1;
            camera.target[1] = 0.5 * sy;
            camera.position[0] = camera.target[0] + 3.0 * sin_t;
            camera.position[1] = camera.target[1] + 3.0 * mu * sy;
            camera.up[2] = 1.0;
            camera.fov_deg = 2.0;
            camera.width = camera.height = 4;
            for (int bounces = 1; bounces <= 1000; bounces += 999) {
                double expected =
                    bounces == 1 ? (side == 0 ? r1 : t1) : (side == 0 ? r_rad[node] : t_rad[node]);
                vdbs_image image;
                double t0 = omp_get_wtime();
                render_camera(&volume, &scene, &camera, 65536, bounces, seed++, &image);
                double mean, se;
                image_mean(&image, &mean, &se);
                print_message("slab radiance g %g %s mu %.4f bounces %d: %.6f +- %.6f, expected "
                              "%.6f (%.2fs)\n",
                              g, side == 0 ? "reflected" : "transmitted", mu, bounces, mean, se,
                              expected, omp_get_wtime() - t0);
                image_drop(&image);
                if (fabs(mean - expected) > fmax(0.01 * expected, 4.0 * se))
                    fail_msg("slab radiance g %g side %d bounces %d: %.6f +- %.6f, expected %.6f",
                             g, side, bounces, mean, se, expected);
            }
        }
    }
    vdbs_volume_free(&volume);
}

/* The radiance leaving a conservative, forward-scattering slab (tau 1, albedo 1, g 0.75,
 * sun at normal incidence) at mu = 1, 0.5 and 0.1, reflected and transmitted, at radiance
 * level: a 16 x 16 camera of 2 degrees 3 units from the slab's centre (its footprint, at
 * most about 1 unit across at mu = 0.1, and the 10 units a grazing ray runs inside the
 * slab stay over 20 units from its edges at +-32.5), 64k samples per pixel, within
 * max(0.3%, 4 standard errors) of adding-doubling. Rays go through pixel centres, so the
 * expected value is the mean of the adding-doubling radiance along each pixel's own
 * cosine (an extra direction of the solver, not an interpolation between its nodes). The
 * extra directions are first checked against the nodes, against single scattering in
 * closed form (albedo 1e-4), and against the solver's own reflected and transmitted
 * fluxes (integrated over 96 extra directions, a rule other than its nodes). */
static void test_slab_radiance_angles(void **state)
{
    (void)state;
    const double tau = 1.0, albedo = 1.0, g = 0.75, mus[3] = {1.0, 0.5, 0.1};
    const int size = 16, spp = 65536, npix = 16 * 16;
    double mu_q[NQ], w_q[NQ];
    test_gauss_legendre(NQ, 0.0, 1.0, mu_q, w_q);

    /* The extra directions against the solver: at nodes, at mu = 1 / 0.5 / 0.1 in the
     * single-scattering limit, and integrated into fluxes. */
    {
        enum { NG = 96, NX = 3 + 2 + NG };
        double x_mu[NX], x_r[NX], x_t[NX], r_flux, t_flux, r_rad[NQ], t_rad[NQ];
        double mu_g[NG], w_g[NG];
        test_gauss_legendre(NG, 0.0, 1.0, mu_g, w_g);
        const int nodes[2] = {0, NQ / 2};
        for (int i = 0; i < 3; ++i)
            x_mu[i] = mus[i];
        for (int i = 0; i < 2; ++i)
            x_mu[3 + i] = mu_q[nodes[i]];
        for (int i = 0; i < NG; ++i)
            x_mu[5 + i] = mu_g[i];
        pp_adding_doubling_dirs(tau, albedo, g, &r_flux, &t_flux, r_rad, t_rad, NX, x_mu, x_r, x_t);
        for (int i = 0; i < 2; ++i) {
            int k = nodes[i];
            print_message("extra direction at node mu %.6f: R %.9g (node %.9g), T %.9g (node "
                          "%.9g)\n",
                          mu_q[k], x_r[3 + i], r_rad[k], x_t[3 + i], t_rad[k]);
            assert_true(fabs(x_r[3 + i] / r_rad[k] - 1.0) < 1e-6);
            assert_true(fabs(x_t[3 + i] / t_rad[k] - 1.0) < 1e-6);
        }
        double fr = 0.0, ft = 0.0;
        for (int i = 0; i < NG; ++i) {
            fr += 2.0 * PI * w_g[i] * mu_g[i] * x_r[5 + i];
            ft += 2.0 * PI * w_g[i] * mu_g[i] * x_t[5 + i];
        }
        double direct = exp(-tau);
        print_message("fluxes from %d extra directions: R %.9f (nodes %.9f), diffuse T %.9f "
                      "(nodes %.9f)\n",
                      NG, fr, r_flux, ft, t_flux - direct);
        assert_true(fabs(fr / r_flux - 1.0) < 1e-5);
        assert_true(fabs(ft / (t_flux - direct) - 1.0) < 1e-5);
        for (int i = 0; i < 3; ++i)
            print_message("adding-doubling at mu %.1f: R %.7f T %.7f\n", mus[i], x_r[i], x_t[i]);

        const double a1 = 1e-4;
        pp_adding_doubling_dirs(tau, a1, g, &r_flux, &t_flux, NULL, NULL, 3, mus, x_r, x_t);
        for (int i = 0; i < 3; ++i) {
            double mu = mus[i];
            double r1 = a1 * hg_phase(g, -mu) / (1.0 + mu) * -expm1(-tau * (1.0 + 1.0 / mu));
            double t1 = mu == 1.0
                            ? a1 * hg_phase(g, 1.0) * tau * exp(-tau)
                            : a1 * hg_phase(g, mu) * (exp(-tau) - exp(-tau / mu)) / (1.0 - mu);
            print_message("albedo 1e-4, mu %.1f: R %.9g (single %.9g), T %.9g (single %.9g)\n", mu,
                          x_r[i], r1, x_t[i], t1);
            assert_true(fabs(x_r[i] / r1 - 1.0) < 1e-3);
            assert_true(fabs(x_t[i] / t1 - 1.0) < 1e-3);
        }
    }

    vdbs_volume volume;
    make_slab(16, 64, &volume);
    vdbs_scene scene;
    medium(&scene, tau, albedo, g);
    add_sun(&scene, 0.0, -1.0, 0.0, 1.0);

    /* Cameras (side 0 above the lit face, side 1 below) and each pixel's cosine. */
    vdbs_camera cameras[3][2];
    double *pix_mu = malloc(sizeof(double) * 6 * npix);
    for (int m = 0; m < 3; ++m)
        for (int side = 0; side < 2; ++side) {
            double sy = side == 0 ? 1.0 : -1.0, mu = mus[m], sin_t = sqrt(1.0 - mu * mu);
            vdbs_camera *camera = &cameras[m][side];
            memset(camera, 0, sizeof *camera);
            camera->present = 1;
            camera->target[1] = 0.5 * sy;
            camera->position[0] = camera->target[0] + 3.0 * sin_t;
            camera->position[1] = camera->target[1] + 3.0 * mu * sy;
            camera->up[2] = 1.0; /* never parallel to the view, which has no z */
            camera->fov_deg = 2.0;
            camera->width = camera->height = size;
            vdbs_camera_frame frame;
            vdbs_error err;
            assert_int_equal(vdbs_camera_frame_init(camera, &frame, &err), VDBS_OK);
            for (int py = 0; py < size; ++py)
                for (int px = 0; px < size; ++px) {
                    double dir[3];
                    vdbs_camera_ray(&frame, px + 0.5, py + 0.5, dir);
                    /* The observer direction -dir leaves through the face seen. */
                    assert_true(-dir[1] * sy > 0.0);
                    pix_mu[(2 * m + side) * npix + py * size + px] = fabs(dir[1]);
                }
        }
    double *pix_r = malloc(sizeof(double) * 6 * npix), *pix_t = malloc(sizeof(double) * 6 * npix);
    double r_flux, t_flux;
    pp_adding_doubling_dirs(tau, albedo, g, &r_flux, &t_flux, NULL, NULL, 6 * npix, pix_mu, pix_r,
                            pix_t);

    uint64_t seed = 700;
    double total = 0.0;
    int failed = 0;
    char why[1024] = "";
    for (int m = 0; m < 3; ++m)
        for (int side = 0; side < 2; ++side) {
            const double *rad = side == 0 ? pix_r : pix_t;
            double expected = 0.0, lo = 1.0, hi = 0.0;
            for (int i = 0; i < npix; ++i) {
                double mu = pix_mu[(2 * m + side) * npix + i];
                expected += rad[(2 * m + side) * npix + i];
                lo = fmin(lo, mu);
                hi = fmax(hi, mu);
            }
            expected /= npix;
            vdbs_image image;
            double t0 = omp_get_wtime();
            render_camera(&volume, &scene, &cameras[m][side], spp, 100000, seed++, &image);
            double dt = omp_get_wtime() - t0;
            total += dt;
            double mean, se;
            image_mean(&image, &mean, &se);
            image_drop(&image);
            double tol = fmax(0.003 * expected, 4.0 * se);
            print_message("slab tau 1 albedo 1 g 0.75 %s mu %.1f (pixels %.4f..%.4f): %.6f +- "
                          "%.6f (%.3f%%), expected %.6f, difference %+.3f%% = %+.2f se, bar "
                          "%.3f%% (%.1fs)\n",
                          side == 0 ? "reflected" : "transmitted", mus[m], lo, hi, mean, se,
                          100.0 * se / expected, expected, 100.0 * (mean / expected - 1.0),
                          (mean - expected) / se, 100.0 * tol / expected, dt);
            if (fabs(mean - expected) > tol) {
                size_t used = strlen(why);
                snprintf(why + used, sizeof why - used, "; %s mu %.1f: %.6f +- %.6f, expected %.6f",
                         side == 0 ? "reflected" : "transmitted", mus[m], mean, se, expected);
                ++failed;
            }
        }
    print_message("slab radiance at mu 1, 0.5, 0.1: %.1fs rendering\n", total);
    free(pix_mu);
    free(pix_r);
    free(pix_t);
    vdbs_volume_free(&volume);
    if (failed)
        fail_msg("slab radiance tau 1 albedo 1 g 0.75: %d of 6 cases beyond max(0.3%%, 4 se) "
                 "of adding-doubling%s",
                 failed, why);
}

/* Interpolated density of an n^3 block of ones at index point u: separable, one ramp
 * per axis from 1 at the outer centres to 0 one voxel further out. */
static double block_density(int n, const double u[3])
{
    double d = 1.0;
    for (int a = 0; a < 3; ++a) {
        double out = u[a] < 0.0 ? -u[a] : (u[a] > n - 1 ? u[a] - (n - 1) : 0.0);
        d *= fmax(0.0, 1.0 - out);
    }
    return d;
}

/* Optical depth between two world points through the block (voxel size h, voxel 0 at
 * the origin), by the midpoint rule. */
static double block_depth(int n, double h, double sigma, const double a[3], const double b[3])
{
    const int m = 400;
    double len = sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                      (b[2] - a[2]) * (b[2] - a[2]));
    double sum = 0.0;
    for (int i = 0; i < m; ++i) {
        double f = (i + 0.5) / m, u[3];
        for (int k = 0; k < 3; ++k)
            u[k] = (a[k] + f * (b[k] - a[k])) / h;
        sum += block_density(n, u);
    }
    return sum / m * len * sigma;
}

/* Single scattering of a point light by a homogeneous block, against quadrature along
 * each pixel's ray of sigma_s p I / r^2 with both transmittances. */
static void test_point_single(void **state)
{
    (void)state;
    const int n = 12;
    const double h = 0.1, sigma = 1.5, albedo = 0.8, g = 0.4;
    float values[12 * 12 * 12];
    for (int i = 0; i < n * n * n; ++i)
        values[i] = 1.0f;
    int dims[3] = {n, n, n};
    double m[3][4] = {{h, 0.0, 0.0, 0.0}, {0.0, h, 0.0, 0.0}, {0.0, 0.0, h, 0.0}};
    vdbs_volume volume;
    make_volume(values, dims, m, &volume);
    vdbs_scene scene;
    medium(&scene, sigma, albedo, g);
    const double light[3] = {1.6, 1.4, 0.2}, intensity = 3.0;
    add_point(&scene, light[0], light[1], light[2], intensity);

    vdbs_camera camera = {0};
    camera.present = 1;
    camera.position[0] = 0.3;
    camera.position[1] = 0.7;
    camera.position[2] = 4.0;
    camera.target[0] = camera.target[1] = camera.target[2] = 0.55;
    camera.fov_deg = 10.0;
    camera.width = camera.height = 3;
    vdbs_image image;
    render_camera(&volume, &scene, &camera, 200000, 1, 77, &image);

    vdbs_camera_frame frame;
    vdbs_error err;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    for (int py = 0; py < 3; ++py)
        for (int px = 0; px < 3; ++px) {
            double dir[3];
            vdbs_camera_ray(&frame, px + 0.5, py + 0.5, dir);
            /* The block's support is [-h, n h] per axis; march the ray across it. */
            double t_lo = 0.0, t_hi = 1e30;
            for (int a = 0; a < 3; ++a) {
                double ta = (-h - frame.origin[a]) / dir[a];
                double tb = (n * h - frame.origin[a]) / dir[a];
                t_lo = fmax(t_lo, fmin(ta, tb));
                t_hi = fmin(t_hi, fmax(ta, tb));
            }
            double expected = 0.0;
            if (t_lo < t_hi) {
                const int steps = 1000;
                double dt = (t_hi - t_lo) / steps, depth = 0.0;
                double entry[3];
                for (int a = 0; a < 3; ++a)
                    entry[a] = frame.origin[a] + t_lo * dir[a];
                for (int i = 0; i < steps; ++i) {
                    double t = t_lo + (i + 0.5) * dt, x[3], u[3], v[3];
                    for (int a = 0; a < 3; ++a) {
                        x[a] = frame.origin[a] + t * dir[a];
                        u[a] = x[a] / h;
                        v[a] = light[a] - x[a];
                    }
                    double r = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
                    /* Cosine between the light's propagation -v and the outgoing -dir. */
                    double cos_s = (v[0] * dir[0] + v[1] * dir[1] + v[2] * dir[2]) / r;
                    depth = block_depth(n, h, sigma, entry, x);
                    double s = sigma * block_density(n, u);
                    expected += s * albedo * hg_phase(g, cos_s) * intensity / (r * r) *
                                exp(-depth - block_depth(n, h, sigma, x, light)) * dt;
                }
            }
            double got = image.rgb[3 * (py * 3 + px)], se = image.se[3 * (py * 3 + px)];
            print_message("point light pixel (%d,%d): %.6f +- %.6f, expected %.6f\n", px, py, got,
                          se, expected);
            if (fabs(got - expected) > fmax(0.01 * expected, 4.0 * se))
                fail_msg("pixel (%d,%d): %.6f +- %.6f, expected %.6f", px, py, got, se, expected);
        }
    image_drop(&image);
    vdbs_volume_free(&volume);
}

/* The single-scatter march of a scene on the CPU backend (1/32-voxel steps: the midpoint rule
 * errs by D^2 / 8 per segment) with K sky ordinates and exact light marches. */
static void march_render(const vdbs_volume *volume, const vdbs_scene *scene,
                         const vdbs_camera_frame *frame, int sky_directions, vdbs_image *image)
{
    vdbs_error err;
    vdbs_march_options options = {0};
    options.sky_directions = sky_directions;
    options.step_voxels = 1.0f / 32.0f;
    options.s1_march = 1;
    image_make(image, frame->width, frame->height);
    vdbs_runner *runner = NULL;
    vdbs_runner_desc rd = {.backend = VDBS_BACKEND_CPU};
    assert_int_equal(vdbs_runner_create(&rd, &runner, &err), VDBS_OK);
    if (vdbs_render_march(runner, volume, NULL, scene, frame, &options, image, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_runner_destroy(runner);
}

/* A sample lit by the test sky (a lat-long map with a small bright sun): the reference
 * with one bounce (map NEE by luminance x solid angle, MIS with HG sampling) against the
 * single-scatter march (exact light marches to K importance-sampled ordinates), on the sphere
 * and cloud samples: within the reference's noise at K = 1024 (|mean z| <= 4 / sqrt(N), rms z
 * <= 1.2, each channel over its N pixels), and the march's quadrature error falls from K = 16
 * to K = 1024.
 *
 * The z criteria need a standard error that means something: a pixel whose camera ray
 * collides in a handful of the samples has an estimated se near zero whatever its true error
 * (a 32x32 cloud at 1000 spp shows z = -21 where 1 - T = 0.003). So the criteria count the
 * pixels where at least 5% of the rays collide (50 expected collisions at 1000 spp), with T
 * from the march of the same volume without scattering under a unit sky. Background pixels
 * are tested to 1e-5 in test_envmap.c. 32x32 pixels give the criteria enough pixels (N of
 * about 250 on the cloud: chance exceeds rms z 1.2 with a probability near 1e-5). */
static void env_map_single(const char *sample, double density_scale)
{
    vdbs_error err;
    vdbs_image sky;
    assert_int_equal(vdbs_envmap_test_sky(32, &sky, &err), VDBS_OK);
    const char *path = test_tmp_path("stat_sky.exr");
    assert_int_equal(vdbs_image_write(path, &sky, 0.0, &err), VDBS_OK);
    vdbs_image_free(&sky);
    vdbs_volume volume;
    make_sample(sample, 24, &volume);
    const int size = 32, spp = 1000;
    vdbs_camera camera;
    vdbs_camera_frame_volume(&volume, size, size, &camera);
    vdbs_camera_frame frame;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);

    vdbs_scene absorber;
    medium(&absorber, density_scale, 0.0, 0.3);
    add_env(&absorber, 1.0, 1.0, 1.0);
    assert_int_equal(vdbs_scene_validate(&absorber, &err), VDBS_OK);
    vdbs_image transmittance;
    march_render(&volume, &absorber, &frame, 16, &transmittance);

    vdbs_scene scene;
    medium(&scene, density_scale, 0.8, 0.3);
    add_env(&scene, 1.0, 1.0, 1.0);
    assert_int_equal(vdbs_light_set_env_file(&scene, &scene.lights[0], path, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(&scene, &err), VDBS_OK);
    vdbs_image ref;
    render(&volume, &scene, size, spp, 1, 91, &ref);
    const int ks[2] = {16, 1024};
    double rms_diff[2];
    for (int i = 0; i < 2; ++i) {
        vdbs_image march;
        march_render(&volume, &scene, &frame, ks[i], &march);
        double sum_d2 = 0.0, sum_r2 = 0.0;
        for (int v = 0; v < 3 * size * size; ++v) {
            double d = ref.rgb[v] - march.rgb[v];
            sum_d2 += d * d;
            sum_r2 += (double)ref.rgb[v] * ref.rgb[v];
        }
        rms_diff[i] = sqrt(sum_d2 / sum_r2);
        for (int c = 0; c < 3; ++c) {
            double sum_z = 0.0, sum_z2 = 0.0;
            int n = 0;
            for (int p = 0; p < size * size; ++p) {
                if (1.0 - transmittance.rgb[3 * p + 1] < 0.05)
                    continue;
                double z = (ref.rgb[3 * p + c] - march.rgb[3 * p + c]) / ref.se[3 * p + c];
                sum_z += z;
                sum_z2 += z * z;
                ++n;
            }
            double mean_z = sum_z / n, rms_z = sqrt(sum_z2 / n);
            print_message("%s under the test sky, K %4d, channel %d: reference (1 bounce) "
                          "against the march: mean z %+.3f, rms z %.3f over %d pixels\n",
                          sample, ks[i], c, mean_z, rms_z, n);
            if (i == 1) {
                assert_true(n >= 150);
                assert_true(fabs(mean_z) <= 4.0 / sqrt(n));
                assert_true(rms_z <= 1.2);
            }
        }
        print_message("%s under the test sky, K %4d: relative RMS difference %.2e\n", sample, ks[i],
                      rms_diff[i]);
        image_drop(&march);
    }
    assert_true(rms_diff[1] < rms_diff[0]);
    image_drop(&ref);
    image_drop(&transmittance);
    vdbs_volume_free(&volume);
}

static void test_env_map_single(void **state)
{
    (void)state;
    env_map_single("sphere", 3.0);
    env_map_single("cloud", 8.0);
}

/* Single scattering of a normal beam by an isotropic slab: the reflected flux is
 * (albedo / 2) int_0^1 mu / (1 + mu) (1 - exp(-tau (1 + 1/mu))) dmu. */
static double single_reflection(double tau, double albedo)
{
    const int m = 200000;
    double s = 0.0;
    for (int i = 0; i < m; ++i) {
        double mu = (i + 0.5) / m;
        s += mu / (1.0 + mu) * (1.0 - exp(-tau * (1.0 + 1.0 / mu)));
    }
    return 0.5 * albedo * s / m;
}

static void test_adding_doubling_checks(void **state)
{
    (void)state;
    /* The independent solver itself: no scattering gives exp(-tau); albedo 1 conserves
     * energy; a weakly scattering slab reflects its single-scattering closed form. */
    double r, t;
    pp_adding_doubling(2.0, 0.0, 0.5, &r, &t, NULL, NULL);
    assert_true(fabs(t - exp(-2.0)) < 1e-9 && fabs(r) < 1e-12);
    pp_adding_doubling(1.0, 1.0, 0.9, &r, &t, NULL, NULL);
    assert_true(fabs(r + t - 1.0) < 1e-5);
    pp_adding_doubling(4.0, 1.0, 0.0, &r, &t, NULL, NULL);
    assert_true(fabs(r + t - 1.0) < 1e-5);
    for (int k = 0; k < 2; ++k) {
        double tau = k ? 4.0 : 1.0, r1 = single_reflection(tau, 1e-4);
        pp_adding_doubling(tau, 1e-4, 0.0, &r, &t, NULL, NULL);
        print_message("tau %g: single-scattering R %.9g, adding-doubling %.9g\n", tau, r1, r);
        assert_true(fabs(r / r1 - 1.0) < 1e-3);
    }
}

static void test_energy_sphere(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_sample("sphere", 32, &volume);
    const double centre[3] = {0.0, 0.0, 0.0};
    vdbs_error err;
    vdbs_reference_tally tally;

    /* Albedo 1: everything that enters leaves. */
    vdbs_scene scene;
    medium(&scene, 8.0, 1.0, 0.5);
    add_sun(&scene, 0.2, -1.0, 0.1, 1.0);
    if (vdbs_reference_tally_sun(&volume, &scene, centre, 0.8, 400000, 1 << 20, 5, &tally, &err) !=
        VDBS_OK)
        fail_msg("%s", err.message);
    print_message("sphere albedo 1: R %.5f T %.5f A %.3g +- %.3g\n", tally.reflected,
                  tally.transmitted, tally.absorbed, tally.absorbed_se);
    assert_true(fabs(tally.absorbed) <= 4.0 * tally.absorbed_se);
    assert_true(fabs(tally.reflected + tally.transmitted - 1.0) <=
                fmax(1e-12, 4.0 * (tally.reflected_se + tally.transmitted_se)));
    assert_true(tally.reflected > 0.2);

    /* Albedo 0.8 with roulette: reflected + transmitted + absorbed = 1 in expectation
     * (the sum's standard error is at most the sum of the three). */
    medium(&scene, 8.0, 0.8, 0.5);
    add_sun(&scene, 0.2, -1.0, 0.1, 1.0);
    if (vdbs_reference_tally_sun(&volume, &scene, centre, 0.8, 400000, 1 << 20, 6, &tally, &err) !=
        VDBS_OK)
        fail_msg("%s", err.message);
    double sum = tally.reflected + tally.transmitted + tally.absorbed;
    double se = tally.reflected_se + tally.transmitted_se + tally.absorbed_se;
    print_message("sphere albedo 0.8: R %.5f T %.5f A %.5f sum %.5f +- %.5f\n", tally.reflected,
                  tally.transmitted, tally.absorbed, sum, se);
    assert_true(fabs(sum - 1.0) <= 4.0 * se);
    vdbs_volume_free(&volume);
}

static void sphere_scene(vdbs_scene *scene)
{
    medium(scene, 4.0, 0.9, 0.3);
    add_sun(scene, 0.3, -1.0, 0.2, 2.0);
    add_env(scene, 0.1, 0.15, 0.25);
}

static double rms_diff(const vdbs_image *a, const vdbs_image *b)
{
    double s = 0.0;
    size_t n = (size_t)3 * a->width * a->height;
    for (size_t i = 0; i < n; ++i)
        s += ((double)a->rgb[i] - b->rgb[i]) * ((double)a->rgb[i] - b->rgb[i]);
    return sqrt(s / n);
}

static void test_noise_falls(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_sample("sphere", 32, &volume);
    vdbs_scene scene;
    sphere_scene(&scene);
    double rms[2];
    const int spps[2] = {16, 256};
    for (int k = 0; k < 2; ++k) {
        vdbs_image a, b;
        render(&volume, &scene, 64, spps[k], 64, 100, &a);
        render(&volume, &scene, 64, spps[k], 64, 200, &b);
        rms[k] = rms_diff(&a, &b);
        image_drop(&a);
        image_drop(&b);
    }
    print_message("rms difference: %g at 16 spp, %g at 256 spp, ratio %.3f\n", rms[0], rms[1],
                  rms[0] / rms[1]);
    assert_true(rms[1] > 0.0);
    assert_true(fabs(rms[0] / rms[1] / 4.0 - 1.0) < 0.15);
    vdbs_volume_free(&volume);
}

static void test_deterministic_threads(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_sample("sphere", 32, &volume);
    vdbs_scene scene;
    sphere_scene(&scene);
    add_point(&scene, 1.2, 0.8, 1.0, 2.0);
    int threads = omp_get_max_threads();
    vdbs_image a, b;
    omp_set_num_threads(1);
    render(&volume, &scene, 24, 8, 16, 42, &a);
    omp_set_num_threads(2);
    render(&volume, &scene, 24, 8, 16, 42, &b);
    omp_set_num_threads(threads);
    size_t bytes = sizeof(float) * 3 * 24 * 24;
    assert_memory_equal(a.rgb, b.rgb, bytes);
    assert_memory_equal(a.se, b.se, bytes);
    double mean = 0.0;
    for (int i = 0; i < 3 * 24 * 24; ++i)
        mean += a.rgb[i];
    assert_true(mean > 0.0);
    image_drop(&a);
    image_drop(&b);
    vdbs_volume_free(&volume);
}

/* Rounds under a time limit merge into the same mean and standard error as one render
 * of all their samples (same seed: the sample indices continue across rounds). */
static void test_time_limit(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_sample("sphere", 16, &volume);
    vdbs_scene scene;
    sphere_scene(&scene);
    vdbs_camera camera;
    vdbs_camera_frame_volume(&volume, 8, 8, &camera);
    vdbs_camera_frame frame;
    vdbs_error err;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_progress progress;
    vdbs_progress_begin(&progress, 0, "reference", 100);
    vdbs_reference_options options = {0};
    options.spp = 3;
    options.time_limit = 0.2;
    options.max_bounces = 8;
    options.seed = 5;
    options.progress = &progress;
    vdbs_image a, b;
    image_make(&a, 8, 8);
    int done = 0;
    assert_int_equal(vdbs_reference_render(&volume, &scene, &frame, &options, &a, &done, &err),
                     VDBS_OK);
    assert_true(done >= 3 && done % 3 == 0);
    options.spp = done;
    options.time_limit = 0.0;
    image_make(&b, 8, 8);
    int done_b = 0;
    assert_int_equal(vdbs_reference_render(&volume, &scene, &frame, &options, &b, &done_b, &err),
                     VDBS_OK);
    assert_int_equal(done_b, done);
    print_message("time limit: %d samples per pixel\n", done);
    for (int i = 0; i < 3 * 64; ++i) {
        assert_true(fabs(a.rgb[i] - b.rgb[i]) <= 1e-5 * fabs(b.rgb[i]) + 1e-30);
        assert_true(fabs(a.se[i] - b.se[i]) <= 1e-3 * fabs(b.se[i]) + 1e-30);
    }
    image_drop(&a);
    image_drop(&b);
    vdbs_volume_free(&volume);
}

/* Analytic HG CDF in mu (probability that the cosine is <= mu); it divides by g, so
 * below |g| = 1e-9 the isotropic CDF stands in (off by O(g)). */
static double hg_cdf(double g, double mu)
{
    if (fabs(g) < 1e-9)
        return 0.5 * (1.0 + mu);
    return (1.0 - g * g) / (2.0 * g) * (1.0 / sqrt(1.0 + g * g - 2.0 * g * mu) - 1.0 / (1.0 + g));
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void test_hg_sampling(void **state)
{
    (void)state;
    const double gs[] = {0.0, 0.5, -0.7, 0.99};
    const int n = 200000;
    double *mu = malloc(sizeof(double) * n);
    uint64_t x = 88172645463325252ull;
    for (size_t k = 0; k < sizeof gs / sizeof *gs; ++k) {
        double g = gs[k];
        /* The sampler inverts the CDF: F(sample(u)) = u. */
        for (int i = 0; i <= 1000; ++i) {
            double u = i < 1000 ? i / 1000.0 : 1.0 - 1e-12;
            double m = vdbs_reference_hg_sample(g, u);
            assert_true(m >= -1.0 && m <= 1.0);
            assert_true(fabs(hg_cdf(g, m) - u) < 1e-9);
        }
        /* Kolmogorov-Smirnov on random draws (xorshift64*). */
        for (int i = 0; i < n; ++i) {
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            double u = (double)((x * 2685821657736338717ull) >> 11) * 0x1.0p-53;
            mu[i] = vdbs_reference_hg_sample(g, u);
        }
        qsort(mu, n, sizeof *mu, cmp_double);
        double d = 0.0;
        for (int i = 0; i < n; ++i) {
            double f = hg_cdf(g, mu[i]);
            d = fmax(d, fmax(fabs(f - (double)i / n), fabs(f - (double)(i + 1) / n)));
        }
        print_message("HG g %g: KS D = %.5f (1%% critical %.5f)\n", g, d, 1.63 / sqrt(n));
        assert_true(d < 1.63 / sqrt(n));
    }
    /* Extremes stay finite and in range. */
    const double extreme[] = {0.999, -0.999, 1e-12, -1e-12};
    for (size_t k = 0; k < sizeof extreme / sizeof *extreme; ++k)
        for (int i = 0; i <= 20; ++i) {
            double u = i < 20 ? i / 20.0 : 1.0 - 1e-16;
            double m = vdbs_reference_hg_sample(extreme[k], u);
            assert_true(isfinite(m) && m >= -1.0 && m <= 1.0);
            assert_true(fabs(hg_cdf(extreme[k], m) - u) < 1e-6);
        }
    free(mu);
}

static void check_finite(const vdbs_image *image, const char *what)
{
    for (int i = 0; i < 3 * image->width * image->height; ++i)
        if (!(isfinite(image->rgb[i]) && image->rgb[i] >= 0.0f && isfinite(image->se[i]) &&
              image->se[i] >= 0.0f))
            fail_msg("%s: pixel value %d is %g (se %g)", what, i, image->rgb[i], image->se[i]);
}

static void test_extremes(void **state)
{
    (void)state;
    const int n = 6;
    float values[6 * 6 * 6];
    for (int i = 0; i < n * n * n; ++i)
        values[i] = 1.0f;
    int dims[3] = {n, n, n};
    double m[3][4] = {{0.1, 0.0, 0.0, 0.0}, {0.0, 0.1, 0.0, 0.0}, {0.0, 0.0, 0.1, 0.0}};
    vdbs_volume volume;
    make_volume(values, dims, m, &volume);
    /* Optical thickness per voxel 1e-6 and 1e4 (voxel size 0.1). */
    const double scales[] = {1e-5, 1e5};
    const double albedos[] = {0.0, 1.0};
    const double gs[] = {0.0, 0.999, -0.999};
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int c = 0; c < 3; ++c) {
                vdbs_scene scene;
                medium(&scene, scales[a], albedos[b], gs[c]);
                add_sun(&scene, 0.3, -1.0, 0.2, 1e6);
                add_point(&scene, 0.25, 0.25, 0.25, 1e-6);
                add_point(&scene, 1.0, 0.9, 0.3, 1e6);
                add_env(&scene, 1e-6, 1.0, 1e6);
                vdbs_image image;
                render(&volume, &scene, 8, 4, 64, 3, &image);
                char what[128];
                snprintf(what, sizeof what, "scale %g albedo %g g %g", scales[a], albedos[b],
                         gs[c]);
                check_finite(&image, what);
                image_drop(&image);
                vdbs_reference_tally tally;
                vdbs_error err;
                const double centre[3] = {0.25, 0.25, 0.25};
                assert_int_equal(vdbs_reference_tally_sun(&volume, &scene, centre, 0.3, 2000, 64, 9,
                                                          &tally, &err),
                                 VDBS_OK);
                assert_true(isfinite(tally.reflected) && isfinite(tally.transmitted) &&
                            isfinite(tally.absorbed));
                assert_true(tally.reflected >= 0.0 && tally.transmitted >= 0.0 &&
                            tally.absorbed >= 0.0);
            }
    vdbs_volume_free(&volume);

    /* An empty grid shows the sky only, with no noise. */
    float zero[8] = {0};
    int dims2[3] = {2, 2, 2};
    make_volume(zero, dims2, m, &volume);
    vdbs_scene scene;
    medium(&scene, 1.0, 0.5, 0.0);
    add_sun(&scene, 0.0, -1.0, 0.0, 1.0);
    add_env(&scene, 0.25, 0.5, 1.0);
    vdbs_image image;
    render(&volume, &scene, 4, 3, 8, 1, &image);
    for (int i = 0; i < 3 * 16; ++i) {
        assert_true(image.rgb[i] == (float)(0.25 * (1 << (i % 3))));
        assert_true(image.se[i] == 0.0f);
    }
    image_drop(&image);
    vdbs_volume_free(&volume);
}

static void test_errors(void **state)
{
    (void)state;
    vdbs_volume volume;
    make_sample("sphere", 8, &volume);
    vdbs_scene scene;
    medium(&scene, 1.0, 0.5, 0.0);
    add_env(&scene, 1.0, 1.0, 1.0);
    vdbs_error err;
    const char *missing = test_tmp_path("no_such_sky.exr");
    assert_int_equal(vdbs_light_set_env_file(&scene, &scene.lights[0], missing, &err), VDBS_OK);
    vdbs_camera camera;
    vdbs_camera_frame_volume(&volume, 4, 4, &camera);
    vdbs_camera_frame frame;
    assert_int_equal(vdbs_camera_frame_init(&camera, &frame, &err), VDBS_OK);
    vdbs_image image;
    image_make(&image, 4, 4);
    vdbs_reference_options options = {0};
    options.spp = 1;
    options.max_bounces = 1;
    assert_int_equal(vdbs_reference_render(&volume, &scene, &frame, &options, &image, NULL, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "no_such_sky.exr")); /* a map that cannot be read */
    scene.lights[0].env_map = 0;                             /* a constant env again */
    options.max_bounces = 0;
    assert_int_equal(vdbs_reference_render(&volume, &scene, &frame, &options, &image, NULL, &err),
                     VDBS_ERR_INPUT);
    const double centre[3] = {0.0, 0.0, 0.0};
    vdbs_reference_tally tally;
    assert_int_equal(vdbs_reference_tally_sun(&volume, &scene, centre, 0.5, 10, 4, 1, &tally, &err),
                     VDBS_ERR_INPUT);
    image_drop(&image);
    vdbs_volume_free(&volume);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hg_sampling),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_extremes),
        cmocka_unit_test(test_deterministic_threads),
        cmocka_unit_test(test_time_limit),
        cmocka_unit_test(test_adding_doubling_checks),
        cmocka_unit_test(test_energy_sphere),
        cmocka_unit_test(test_noise_falls),
        cmocka_unit_test(test_slab),
        cmocka_unit_test(test_slab_radiance),
        cmocka_unit_test(test_slab_radiance_angles),
        cmocka_unit_test(test_point_single),
        cmocka_unit_test(test_env_map_single),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
