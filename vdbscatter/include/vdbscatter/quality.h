/* The quality knob: one preset per step (low, medium, high, ultra) that every solver and the
 * render march read. A solver's own per-quality values sit in its option table (solver.h). */
#ifndef VDBSCATTER_QUALITY_H
#define VDBSCATTER_QUALITY_H

#ifdef __cplusplus
extern "C" {
#endif

/* Steps of the quality ladder. */
#define VDBS_QUALITY_COUNT 4

/* One step of the quality knob. */
typedef struct vdbs_quality {
    const char *name;         /* "low", "medium", "high", "ultra" */
    int sky_directions;       /* quadrature directions for the sky's S1: 16 / 64 / 256 / 1024 */
    float render_step_voxels; /* camera-ray step of the render march: 1, 1/2, 1/4, 1/8 voxel */
    int s1_oversample;        /* S1 light-grid samples per smallest voxel: 1 / 1 / 2 / 2
                                 (bench/defaults.md: 2 costs up to 5x the bake for no
                                 measurable gain at low and medium) */
} vdbs_quality;

/* The preset of a quality name, or NULL if unknown. */
const vdbs_quality *vdbs_quality_find(const char *name);
/* The quality ladder, low to ultra (VDBS_QUALITY_COUNT steps). */
const vdbs_quality *vdbs_quality_list(int *count);
/* The quality's step, 0 (low) to 3 (ultra): the index into a solver's own presets; medium's
 * (1) for NULL or an unknown name. */
int vdbs_quality_level(const char *name);
/* Number of sky quadrature directions for a quality name, or 0 if unknown. */
int vdbs_quality_sky_directions(const char *name);

#ifdef __cplusplus
}
#endif

#endif
