/* Procedural sample volumes, identical on every machine (integer-hash noise). */
#ifndef VDBSCATTER_SAMPLES_H
#define VDBSCATTER_SAMPLES_H

#include <stdint.h>

#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Names accepted by vdbs_sample_create, NULL-terminated: cloud, smoke, sphere, slab, cube. */
extern const char *const vdbs_sample_names[];

/* Fills a dense res^3 array over [-1,1]^3 (voxel size 2/res, identity rotation, voxel
 * centres at -1 + (i + 0.5) * 2/res): values[(k * res + j) * res + i]. `values` must
 * hold res^3 floats. `sphere` (radius 0.8), `slab` (|y| <= 0.25, lit face +Y) and `cube`
 * (half-size 0.6) are homogeneous with density 1 inside (a voxel is inside when its
 * centre is); `cloud` is an fBm-noise cumulus and `smoke` a plume, both sparse with
 * soft edges and deterministic for a given seed. Errors: unknown name, res < 1 or > 1024. */
vdbs_status vdbs_sample_fill(const char *name, int res, uint32_t seed, float *values,
                             vdbs_error *err);

/* The same at time `time` in [0, 1] (smoke only: the plume rising, its head climbing from
 * 30% of the still plume's height to all of it while its billows rise, so that the box grows
 * from frame to frame; a coherent sequence for tests and benches), or -1 for the still
 * sample. */
vdbs_status vdbs_sample_fill_at(const char *name, int res, uint32_t seed, double time,
                                float *values, vdbs_error *err);

/* The transform of a sample grid of resolution res: index (0,0,0) is the voxel whose
 * centre is (-1 + h/2, -1 + h/2, -1 + h/2), h = 2/res. */
void vdbs_sample_transform(int res, vdbio_transform *transform);

/* vdbs_sample_fill + vdbio_density_from_dense (grid name "density"). */
vdbs_status vdbs_sample_create(const char *name, int res, uint32_t seed, vdbio_density **out,
                               vdbs_error *err);
/* The same at a time (vdbs_sample_fill_at). */
vdbs_status vdbs_sample_create_at(const char *name, int res, uint32_t seed, double time,
                                  vdbio_density **out, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
