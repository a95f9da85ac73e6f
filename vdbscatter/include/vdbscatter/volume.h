/* A density volume ready for the solvers: the NanoVDB buffer that C and GLSL read,
 * its affine transform both ways, and the list of output voxels. */
#ifndef VDBSCATTER_VOLUME_H
#define VDBSCATTER_VOLUME_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_volume {
    vdbio_density *density; /* owned */
    vdbio_density_info info;
    uint32_t *nano; /* NanoVDB float grid, owned */
    size_t nano_size;
    double index_to_world[3][4];
    double world_to_index[3][4];
    double mean_voxel_size; /* mean world length of the three index axes */
    int32_t *coords;        /* output voxels: active region dilated by one voxel (xyz triples) */
    size_t coord_count;
} vdbs_volume;

/* Reads a density grid and prepares it (see vdbio_density_read for the errors). */
vdbs_status vdbs_volume_load(const char *path, const vdbio_read_options *options,
                             vdbs_volume *volume, vdbs_error *err);

/* Prepares an already built density grid; takes ownership of it (also on failure). */
vdbs_status vdbs_volume_from_density(vdbio_density *density, vdbs_volume *volume, vdbs_error *err);

void vdbs_volume_free(vdbs_volume *volume);

/* The 8^3 bricks (OpenVDB's leaves: origins at multiples of 8) that hold output voxels,
 * counted in the coords' order (leaf by leaf as read; an overcount, never an undercount,
 * were they not). */
int64_t vdbs_volume_leaf_count(const vdbs_volume *volume);
/* The same for OpenVDB's nodes of each level, leaves first: 8^3, 128^3 and 4096^3 voxels. */
void vdbs_volume_node_counts(const vdbs_volume *volume, int64_t counts[3]);

/* The inverse of an affine index-to-world map (vdbio_transform's layout); 0 when it is
 * singular (inv untouched). */
int vdbs_affine_invert(const double m[3][4], double inv[3][4]);

/* Index-space image of a world-space vector (linear part of the inverse map). */
void vdbs_volume_index_vector(const vdbs_volume *volume, const double world[3], double index[3]);
void vdbs_volume_index_point(const vdbs_volume *volume, const double world[3], double index[3]);
void vdbs_volume_world_point(const vdbs_volume *volume, const double index[3], double world[3]);
/* The world centre of output voxel n (volume->coords[3 n ...]). */
void vdbs_volume_voxel_point(const vdbs_volume *volume, size_t n, double world[3]);
/* |det| of the index-to-world map: a voxel's world volume. */
double vdbs_volume_voxel_volume(const vdbs_volume *volume);

/* For a sun travelling along `direction` (any length): its unit travel direction
 * (`unit`, may be NULL) and the index-space image of a unit world step towards it
 * (`towards`), as marches measure t in world units. Returns 0 for a zero direction. */
int vdbs_volume_sun_step(const vdbs_volume *volume, const double direction[3], double unit[3],
                         double towards[3]);

/* Index-space box outside which the interpolated density is 0: the active bounding
 * box grown by one voxel (the trilinear ramp beyond the outermost centres). */
void vdbs_volume_support_box(const vdbs_volume *volume, float lo[3], float hi[3]);
/* The support box's eight corners in world space (corner c takes hi on axis a where bit a of c
 * is set). */
void vdbs_volume_support_corners(const vdbs_volume *volume, double corners[8][3]);
/* The world axis-aligned bounds of the support box. */
void vdbs_volume_support_bounds(const vdbs_volume *volume, double lo[3], double hi[3]);
/* The largest side of the world axis-aligned bounds of the support box: the extent the
 * solvers' grids divide into cells. */
double vdbs_volume_support_extent(const vdbs_volume *volume);
/* World distances from p to the nearest point of the support box (0 inside) and to its
 * farthest corner. */
void vdbs_volume_support_distances(const vdbs_volume *volume, const double p[3], double *near,
                                   double *far);
/* 1 when a world point lies in the support box. */
int vdbs_volume_in_support(const vdbs_volume *volume, const double world[3]);

/* Marches one compute-shader invocation may run in one dispatch under the loop limit that
 * shaders/vs_pass.h explains (the runner's first guess of units per pass). A march crosses
 * at most sum(hi - lo) + 3 cell planes of the support box, one iteration per plane plus
 * two; half the limit is left for PNanoVDB's root-tile loops and the caller's own loops. */
int vdbs_volume_gpu_marches_per_pass(const vdbs_volume *volume);

/* Optical thickness of a volume for a density scale, for `info`: the largest per-voxel
 * depth (max density * scale * mean voxel size) and the depth of straight rays along
 * each index axis through a lattice of up to 64 x 64 positions across the bounding box
 * (mean over rays that meet any density, and max). */
typedef struct vdbs_thickness {
    double voxel_max;
    double axis_mean[3];
    double axis_max[3];
    int axis_rays_hit[3];
} vdbs_thickness;

void vdbs_volume_thickness(const vdbs_volume *volume, double density_scale, vdbs_thickness *out);
/* The mean of the axis means over the axes whose rays met density: the mean optical depth
 * through the volume (0 without density). */
double vdbs_thickness_mean(const vdbs_thickness *t);

#ifdef __cplusplus
}
#endif

#endif
