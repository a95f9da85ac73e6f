/* The seam measure (docs/design.md "Upsampling without seams"): does a per-voxel field show
 * the solver's coarse cells? Along each index axis, every line of voxels through the volume's
 * bounding box gives the second difference d2[i] = m[i+1] - 2 m[i] + m[i-1] of the field's
 * luminance m where all three voxels are in the medium (0 elsewhere); a Hann window over the
 * line, then the power of its DFT at the cell frequency 1 / (cell size in voxels) and at
 * four neighbouring frequencies (+-2 and +-3 bins of the line, outside the window's main
 * lobe), each summed over all lines. The ratio: power at the cell frequency over the mean of
 * the neighbours'. A kink on every plane of cell centres (trilinear reconstruction) is a
 * spike train in d2 with a peak at the cell frequency; a smooth field has none (ratio ~1). */
#ifndef VDBS_TEST_SEAMS_H
#define VDBS_TEST_SEAMS_H

#include "vdbscatter/volume.h"

typedef struct test_seams {
    double ratio[3];       /* per index axis; 0 where no line had enough medium */
    double cell_voxels[3]; /* the cell size in voxels along the axis */
    long lines[3];         /* lines that met the medium */
} test_seams;

/* The measure of `field` (3 floats per output voxel of `volume`, luminance taken) for world
 * cells of side `cell_world` (the solver's upsampled grid; its axes are the world's, so
 * index axes must be too, up to scale). The medium: output voxels of density > 0. */
void test_seams_measure(const vdbs_volume *volume, const float *field, double cell_world,
                        test_seams *out);

/* The same on a dense box of nx x ny x nz voxels (x fastest) with its own mask (non-zero: in
 * the medium), for cell sizes in voxels per axis: the measure's core, for synthetic fields. */
void test_seams_dense(const double *m, const unsigned char *inside, const int n[3],
                      const double cell_voxels[3], test_seams *out);

#endif
