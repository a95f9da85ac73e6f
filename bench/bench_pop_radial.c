/* POP's radial grids against the Monte-Carlo probe: the paper's Fig. 10 case (Elek et al. 2014,
 * Sec. 6), a point light of intensity 1 at the centre of a homogeneous sphere of optical
 * radius 2.5 (sigma_s R), albedo 1, g 0 and 0.8. The bundled `sphere` sample (radius 0.8) with
 * density scale 3.125 is the paper's sphere (radius 2.5, sigma_s 1) scaled by 0.32: every
 * optical length is the paper's, and ms scales by 1 / 0.32^2, so the ratios are the paper's.
 *
 * Points: the voxel centres on the diagonal (i, i, i) from the centre outwards, inside the
 * sphere. At each: the probe's ms (ball of --radius-voxels voxels; ms ~ 1/r is harmonic, so the
 * ball average is the centre value up to the curvature of the diffusion profile) with its
 * standard error, and POP's ms at the voxel for each --radial. Writes a markdown table per g
 * and a CSV (g, r/R, probe, se, then POP per radial) for the plot (bench_pop_radial.py).
 *
 * usage: bench_pop_radial [--out bench/pop_radial.md] [--csv FILE] [--res 48]
 *        [--radial 8,16,32] [--g 0,0.8] [--photons N] [--radius-voxels 0.75] [--backend cpu]
 *        [--seed 1] */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/solver.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/volume.h"

#define MAX_LIST 8
#define SPHERE_RADIUS 0.8
#define OPTICAL_RADIUS 2.5

static void die(const char *what, const vdbs_error *err)
{
    fprintf(stderr, "bench_pop_radial: %s: %s\n", what, err ? err->message : "failed");
    exit(1);
}

static int parse_list(const char *s, double *out)
{
    int n = 0;
    while (s && *s && n < MAX_LIST) {
        char *end;
        out[n++] = strtod(s, &end);
        s = *end == ',' ? end + 1 : NULL;
    }
    return n;
}

int main(int argc, char **argv)
{
    const char *out = "bench/pop_radial.md", *csv = NULL, *backend = "cpu";
    int res = 48;
    double radial[MAX_LIST] = {8, 16, 32}, gs[MAX_LIST] = {0.0, 0.8};
    int radial_count = 3, g_count = 2;
    int64_t photons = (int64_t)1 << 22;
    double radius_voxels = 0.75;
    uint64_t seed = 1;
    for (int i = 1; i + 1 < argc; i += 2) {
        const char *k = argv[i], *v = argv[i + 1];
        if (strcmp(k, "--out") == 0)
            out = v;
        else if (strcmp(k, "--csv") == 0)
            csv = v;
        else if (strcmp(k, "--res") == 0)
            res = atoi(v);
        else if (strcmp(k, "--radial") == 0)
            radial_count = parse_list(v, radial);
        else if (strcmp(k, "--g") == 0)
            g_count = parse_list(v, gs);
        else if (strcmp(k, "--photons") == 0)
            photons = (int64_t)strtod(v, NULL);
        else if (strcmp(k, "--radius-voxels") == 0)
            radius_voxels = strtod(v, NULL);
        else if (strcmp(k, "--backend") == 0)
            backend = v;
        else if (strcmp(k, "--seed") == 0)
            seed = (uint64_t)strtoull(v, NULL, 10);
        else {
            fprintf(stderr, "bench_pop_radial: unknown option %s\n", k);
            return 2;
        }
    }
    vdbs_error err;
    vdbio_density *density = NULL;
    vdbs_volume volume;
    if (vdbs_sample_create("sphere", res, 1, &density, &err) != VDBS_OK ||
        vdbs_volume_from_density(density, &volume, &err) != VDBS_OK)
        die("sphere", &err);
    /* The diagonal's voxel centres inside the sphere, and their output voxels. */
    double points[3 * 64], rr[64];
    size_t at[64];
    int count = 0;
    for (int i = res / 2; i < res && count < 64; ++i) {
        double idx[3] = {i, i, i}, w[3];
        vdbs_volume_world_point(&volume, idx, w);
        double r = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        if (r > SPHERE_RADIUS - 0.5 * volume.mean_voxel_size)
            break;
        size_t v = 0;
        while (v < volume.coord_count &&
               !(volume.coords[3 * v] == i && volume.coords[3 * v + 1] == i &&
                 volume.coords[3 * v + 2] == i))
            ++v;
        if (v == volume.coord_count)
            die("a diagonal voxel is not an output voxel", NULL);
        memcpy(points + 3 * count, w, sizeof w);
        rr[count] = r / SPHERE_RADIUS;
        at[count++] = v;
    }
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    strcpy(scene.method, "pop");
    scene.density_scale = OPTICAL_RADIUS / SPHERE_RADIUS;
    scene.albedo[0] = scene.albedo[1] = scene.albedo[2] = 1.0;
    vdbs_light *light = &scene.lights[scene.light_count++];
    memset(light, 0, sizeof *light);
    light->type = VDBS_LIGHT_POINT;
    light->color[0] = light->color[1] = light->color[2] = 1.0;
    vdbs_bake_options o = {0};
    o.scene = &scene;
    if (vdbs_backend_parse(backend, &o.backend, &err) != VDBS_OK)
        die("--backend", &err);
    size_t n = volume.coord_count;
    float *radiance = calloc(3 * n, sizeof(float)), *ms = calloc(3 * n, sizeof(float));
    float *l1[3] = {calloc(3 * n, sizeof(float)), calloc(3 * n, sizeof(float)),
                    calloc(3 * n, sizeof(float))};
    double *pms = calloc(3 * (size_t)count, sizeof(double));
    double *pse = calloc(3 * (size_t)count, sizeof(double));
    double *pop = calloc((size_t)count * MAX_LIST, sizeof(double));
    FILE *f = fopen(out, "w");
    FILE *fc = csv ? fopen(csv, "w") : NULL;
    if (!radiance || !ms || !l1[0] || !l1[1] || !l1[2] || !pms || !pse || !pop || !f ||
        (csv && !fc))
        die("out of memory or cannot write the outputs", NULL);
    fprintf(f,
            "# POP radial grids: a point light at the centre of a homogeneous sphere\n\n"
            "The paper's Fig. 10 case (optical radius %.1f, albedo 1) on the `sphere` sample at "
            "%d^3 (scaled by %.2f; bench/bench_pop_radial.c). ms along the diagonal from the "
            "light, the probe (%lld photons, balls of %.2f voxels) and POP (%s path) per "
            "radial grid N^3; each POP column is POP / probe.\n",
            OPTICAL_RADIUS, res, SPHERE_RADIUS / OPTICAL_RADIUS, (long long)photons, radius_voxels,
            backend);
    if (fc) {
        fprintf(fc, "g,r_over_R,probe,se");
        for (int q = 0; q < radial_count; ++q)
            fprintf(fc, ",pop%d", (int)radial[q]);
        fprintf(fc, "\n");
    }
    for (int gi = 0; gi < g_count; ++gi) {
        scene.g = gs[gi];
        vdbs_reference_probe_options po = {0};
        po.photons = photons;
        po.radius = radius_voxels * volume.mean_voxel_size;
        po.seed = seed;
        double t0 = vdbs_now();
        if (vdbs_reference_probe(&volume, &scene, &po, points, (size_t)count, pms, NULL, pse, NULL,
                                 &err) != VDBS_OK)
            die("probe", &err);
        double probe_seconds = vdbs_now() - t0;
        double pop_seconds[MAX_LIST];
        for (int q = 0; q < radial_count; ++q) {
            if (vdbs_solver_set(&scene, "pop_radial", radial[q], &err) != VDBS_OK)
                die("pop_radial", &err);
            memset(radiance, 0, 3 * n * sizeof(float));
            memset(ms, 0, 3 * n * sizeof(float));
            for (int a = 0; a < 3; ++a)
                memset(l1[a], 0, 3 * n * sizeof(float));
            vdbs_bake_report report;
            if (vdbs_bake_volume(&o, &volume, radiance, ms, l1, &report, &err) != VDBS_OK)
                die("pop", &err);
            pop_seconds[q] = report.seconds_solve;
            for (int p = 0; p < count; ++p) {
                const float *m = ms + 3 * at[p];
                pop[p * MAX_LIST + q] = (m[0] + m[1] + m[2]) / 3.0;
            }
        }
        fprintf(f, "\n## g = %g\n\nprobe %.1f s; POP (S1 + POP)", scene.g, probe_seconds);
        for (int q = 0; q < radial_count; ++q)
            fprintf(f, " %d^3 %.2f s%s", (int)radial[q], pop_seconds[q],
                    q + 1 < radial_count ? "," : "");
        fprintf(f, "\n\n| r / R | probe ms | rel se |");
        for (int q = 0; q < radial_count; ++q)
            fprintf(f, " POP %d^3 / probe |", (int)radial[q]);
        fprintf(f, "\n|---|---|---|");
        for (int q = 0; q < radial_count; ++q)
            fprintf(f, "---|");
        fprintf(f, "\n");
        for (int p = 0; p < count; ++p) {
            double probe = (pms[3 * p] + pms[3 * p + 1] + pms[3 * p + 2]) / 3.0;
            double se = (pse[3 * p] + pse[3 * p + 1] + pse[3 * p + 2]) / 3.0;
            fprintf(f, "| %.3f | %.5g | %.4f |", rr[p], probe, se / probe);
            if (fc)
                fprintf(fc, "%g,%.6f,%.8g,%.8g", scene.g, rr[p], probe, se);
            for (int q = 0; q < radial_count; ++q) {
                fprintf(f, " %.3f |", pop[p * MAX_LIST + q] / probe);
                if (fc)
                    fprintf(fc, ",%.8g", pop[p * MAX_LIST + q]);
            }
            fprintf(f, "\n");
            if (fc)
                fprintf(fc, "\n");
        }
        fflush(f);
        fprintf(stderr, "g %g done (probe %.1f s)\n", scene.g, probe_seconds);
    }
    fclose(f);
    if (fc)
        fclose(fc);
    for (int a = 0; a < 3; ++a)
        free(l1[a]);
    free(radiance);
    free(ms);
    free(pms);
    free(pse);
    free(pop);
    vdbs_volume_free(&volume);
    return 0;
}
