/* The Monte-Carlo probe's moments of the multiply scattered light (vdbs_reference_probe_moments)
 * at given world points, for bench/bench_lobe.py. OUT.f64 (float64): ms of every point (3 a
 * point), then ms_l1 (9 a point), then ms_t2 (18 a point), in the probe's layouts; then their
 * standard errors in the same order.
 *
 * usage: bench_moments IN.vdb SCENE.json POINTS.f64 OUT.f64 --density-scale S [--photons N]
 *        [--radius R] [--seed K]
 * POINTS.f64: x, y, z per point (float64). The density scale is the bake's resolved one (a
 * scene's "auto" is resolved by the bake, not here); the radius is in world units (default:
 * the ball of one voxel's volume, 0.62 voxel). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/reference.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/volume.h"

#define WORDS 30

static int fail(const char *what, const vdbs_error *err)
{
    fprintf(stderr, "bench_moments: %s%s%s\n", what, err ? ": " : "", err ? err->message : "");
    return 2;
}

static double *read_points(const char *path, size_t *count)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    *count = bytes > 0 ? (size_t)bytes / (3 * sizeof(double)) : 0;
    double *p = malloc(3 * sizeof(double) * (*count > 0 ? *count : 1));
    if (p && fread(p, 3 * sizeof(double), *count, f) != *count) {
        free(p);
        p = NULL;
    }
    fclose(f);
    return p;
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: bench_moments IN.vdb SCENE.json POINTS.f64 OUT.f64 "
                        "--density-scale S [--photons N] [--radius R] [--seed K]\n");
        return 2;
    }
    double density_scale = 0.0, radius = 0.0;
    vdbs_reference_probe_options o = {0};
    o.photons = 4000000;
    for (int i = 5; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--density-scale"))
            density_scale = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--photons"))
            o.photons = atoll(argv[i + 1]);
        else if (!strcmp(argv[i], "--radius"))
            radius = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--seed"))
            o.seed = strtoull(argv[i + 1], NULL, 10);
        else
            return fail(argv[i], NULL);
    }
    if (!(density_scale > 0.0))
        return fail("--density-scale must be > 0", NULL);
    vdbs_error err;
    vdbs_scene scene;
    if (vdbs_scene_load(argv[2], &scene, &err) != VDBS_OK)
        return fail(argv[2], &err);
    scene.density_scale = density_scale;
    vdbs_volume volume;
    if (vdbs_volume_load(argv[1], NULL, &volume, &err) != VDBS_OK)
        return fail(argv[1], &err);
    o.radius = radius > 0.0 ? radius : 0.6204 * volume.mean_voxel_size;
    size_t count = 0;
    double *points = read_points(argv[3], &count);
    double *out = calloc(2 * WORDS * (count > 0 ? count : 1), sizeof *out);
    if (!points || !out)
        return fail(argv[3], NULL);
    double *v = out, *se = out + WORDS * count;
    const vdbs_reference_probe_outputs to = {v,  v + 3 * count,  v + 12 * count,
                                             se, se + 3 * count, se + 12 * count};
    if (vdbs_reference_probe_moments(&volume, &scene, &o, points, count, &to, &err) != VDBS_OK)
        return fail("probe", &err);
    FILE *f = fopen(argv[4], "wb");
    if (!f || fwrite(out, sizeof *out, 2 * WORDS * count, f) != 2 * WORDS * count)
        return fail(argv[4], NULL);
    fclose(f);
    free(points);
    free(out);
    vdbs_volume_free(&volume);
    return 0;
}
