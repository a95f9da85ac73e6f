/* Shared by test_seams and test_seams_data: a scene's bake with one solver at a quality on the
 * C path and the seam measure (seams.h) of its ms and ms_l1 grids over the solver's upsampled
 * cells. */
#ifndef VDBS_TEST_SEAMS_BAKE_H
#define VDBS_TEST_SEAMS_BAKE_H

#include "seams.h"
#include "vdbscatter/scene.h"

/* Bakes `scene` (its method and quality as set) on `volume`; fills the measure of ms
 * (`ms`) and of each ms_l1 grid (`l1`, may be NULL) and returns the upsampled cell side. */
double test_seams_bake(const vdbs_volume *volume, const vdbs_scene *scene, test_seams *ms,
                       test_seams l1[3]);

#endif
