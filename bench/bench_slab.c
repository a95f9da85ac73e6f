/* The thin slab of bench/bench_slab.py: writes a homogeneous slab of W x T x W voxels of side 1
 * (density 1, its lit face +Y) to a VDB and prints, as JSON, adding-doubling's diffusely
 * reflected radiance of a normal beam of irradiance 1 at the cosines asked for, for the
 * optical thickness, albedo and g given (tests/planeparallel.h); beside it, discrete ordinates'
 * own answer (`ordinates`) and the same field rebuilt from the two moments a lit VDB carries
 * (`moments`: what a perfect solver's lit VDB renders).
 * usage: bench_slab OUT.vdb W T TAU ALBEDO G MU... */
#include <stdio.h>
#include <stdlib.h>

#include "planeparallel.h"
#include "vdbscatter/vdbio.h"

int main(int argc, char **argv)
{
    if (argc < 8) {
        fprintf(stderr, "usage: bench_slab OUT.vdb W T TAU ALBEDO G MU...\n");
        return 2;
    }
    const int w = atoi(argv[2]), t = atoi(argv[3]);
    const double tau = atof(argv[4]), albedo = atof(argv[5]), g = atof(argv[6]);
    const int n = argc - 7;
    if (w < 1 || t < 1 || n > 16) {
        fprintf(stderr, "bench_slab: bad size or too many cosines\n");
        return 2;
    }
    float *values = malloc(sizeof *values * (size_t)w * t * w);
    if (!values)
        return 1;
    for (size_t i = 0; i < (size_t)w * t * w; ++i)
        values[i] = 1.0f;
    const int dims[3] = {w, t, w};
    vdbs_error err;
    if (vdbio_debug_write_float_grid(argv[1], "density", values, dims, NULL, 0.0f, 0, &err) !=
        VDBS_OK) {
        fprintf(stderr, "bench_slab: %s\n", err.message);
        free(values);
        return 1;
    }
    free(values);
    double mu[16], r[16], t_rad[16], dom[16], lobe[16], refl, trans;
    for (int i = 0; i < n; ++i)
        mu[i] = atof(argv[7 + i]);
    pp_adding_doubling_dirs(tau, albedo, g, &refl, &trans, NULL, NULL, n, mu, r, t_rad);
    pp_moments_reflection(tau, albedo, g, n, mu, dom, lobe);
    printf("{\"R\": %.9g, \"T\": %.9g", refl, trans);
    const char *names[3] = {"radiance", "ordinates", "moments"};
    const double *per_mu[3] = {r, dom, lobe};
    for (int k = 0; k < 3; ++k) {
        printf(", \"%s\": {", names[k]);
        for (int i = 0; i < n; ++i)
            printf("%s\"%g\": %.9g", i ? ", " : "", mu[i], per_mu[k][i]);
        printf("}");
    }
    printf("}\n");
    return 0;
}
