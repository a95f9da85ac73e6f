/* First collisions of a light's unscattered beam, averaged over each output voxel's cube and
 * conserved across the voxel faces (docs/design.md "First collisions"). The point rule,
 * sigma_t E T at the voxel centre, undercounts voxels that are optically thick: it misses the
 * light stopped between a voxel's face and its centre, and all of it at grazing incidence. */
#ifndef VDBSCATTER_COLLISION_H
#define VDBSCATTER_COLLISION_H

#include <stdint.h>

#include "vdbscatter/lights.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The output voxels' face neighbours: 6 per voxel (coords order), -x, +x, -y, +y, -z, +z,
 * each the neighbour's output index or -1 where it is not an output voxel; and each voxel's
 * density, and the largest density of the 3 x 3 x 3 voxels around it. */
typedef struct vdbs_voxel_faces {
    int32_t *neighbour;
    float *density;
    float *density_near;
    size_t count;
} vdbs_voxel_faces;

vdbs_status vdbs_voxel_faces_build(const vdbs_volume *volume, vdbs_voxel_faces *faces,
                                   vdbs_error *err);
/* The bytes the faces of `count` voxels hold once built (the memory estimate's). */
int64_t vdbs_voxel_faces_bytes(size_t count);
void vdbs_voxel_faces_free(vdbs_voxel_faces *faces);

/* One light's first collisions: rate[3 n + ch], per unit world volume, the cube average of
 * sigma E T with sigma = k[ch] density_scale density and T = exp(-k[ch] depth) (k 1 for the
 * beam itself, a scaled medium's 1 - f albedo for delta-M), from the light's optical depth at
 * every output voxel. Optically thin voxels take the point value at the centre; thick ones
 * (and the 26 around them) the average over the cube, blended between (collision.c). By the
 * divergence theorem that average is E times the fall of T through the cube's faces; a face
 * takes the geometric mean of T at the two voxel centres beside it (exact for a homogeneous
 * layer), so for a sun or a sky ordinate every face's flow leaves one voxel and enters the
 * next and the sum over the voxels is what the beam lost. `scratch` holds
 * VDBS_COLLISION_SCRATCH doubles per voxel; `travel`, when not
 * NULL, receives the light's unit world direction of travel at each voxel (3 per voxel). */
#define VDBS_COLLISION_SCRATCH 9

/* exp(-k depth) for a light grid's optical depth: a march stops once the depth passes its
 * limit (VS_TAU_LIMIT, where exp(-depth) is 0 in float), so a depth there stands for any
 * larger one and gives 0 whatever k. A scaled medium's k (delta-M's 1 - f albedo, 0.015 at
 * g 0.999) would otherwise read light deep inside a thick medium (exp(-0.015 x 100) = 0.22). */
double vdbs_beam_transmittance(double k, float depth);

void vdbs_first_collisions(const vdbs_volume *volume, const vdbs_voxel_faces *faces,
                           const vdbs_light_table *lights, int light, const float *depth,
                           double density_scale, const double k[3], double *scratch, double *rate,
                           float *travel);

/* Every light's first collisions summed per output voxel, filled light by light through
 * vdbs_collision_sum_light (a vdbs_s1_light_fn: pass it and the sum to the S1 pass). */
typedef struct vdbs_collision_sum {
    const vdbs_volume *volume;
    const vdbs_light_table *lights;
    double density_scale;
    vdbs_voxel_faces faces;
    double *scratch; /* VDBS_COLLISION_SCRATCH per voxel */
    double *rate;    /* 3 per voxel: the last light's */
    float *travel;   /* 3 per voxel, with flux */
    double *total;   /* 3 per voxel: sum over the lights of the cube-averaged sigma_t E T */
    double *flux;    /* 9 per voxel or NULL: the same times each light's unit travel, x, y, z
                        components of R, G, B */
} vdbs_collision_sum;

/* Zeroed sums for the volume's output voxels; with_flux also sums the first moment. */
vdbs_status vdbs_collision_sum_init(vdbs_collision_sum *sum, const vdbs_volume *volume,
                                    const vdbs_light_table *lights, double density_scale,
                                    int with_flux, vdbs_error *err);
void vdbs_collision_sum_light(void *user, int light, const float *depth);
/* The same with the light's colour times share[ch] (a part of a light handled otherwise). */
void vdbs_collision_sum_share(vdbs_collision_sum *sum, int light, const float *depth,
                              const double share[3]);
void vdbs_collision_sum_free(vdbs_collision_sum *sum);
/* The bytes vdbs_collision_sum_init holds for `count` voxels, its faces included. */
int64_t vdbs_collision_sum_bytes(size_t count, int with_flux);

#ifdef __cplusplus
}
#endif

#endif
