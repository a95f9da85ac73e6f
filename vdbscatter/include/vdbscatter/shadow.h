/* Shadow maps of solid occluders as the kernels read them (shaders/vs_shadow.h): the table
 * is assembled here from depth maps that the viewer rasterises (a sun's orthographic map,
 * a point light's six cube faces), and looked up by the render kernel for S1 and by the
 * fog pass for the lit spans of view rays. */
#ifndef VDBSCATTER_SHADOW_H
#define VDBSCATTER_SHADOW_H

#include <stddef.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The orthographic frame of a sun's map around a world box: w the travel direction (unit),
 * u and v orthonormal to it, the plane through `origin` before the box and `half` the half
 * width that covers the box's bounding sphere; `range` is the depth across it. */
typedef struct vdbs_shadow_sun_frame {
    double origin[3];
    double u[3], v[3], w[3];
    double half;
    double range;
} vdbs_shadow_sun_frame;

/* Errors: a zero direction or an empty box (VDBS_ERR_INPUT). */
vdbs_status vdbs_shadow_sun_frame_fit(const double direction[3], const double box_lo[3],
                                      const double box_hi[3], vdbs_shadow_sun_frame *frame,
                                      vdbs_error *err);

/* A table for `lights` direct lights (the light table's order), every entry "no map" until
 * set. Free with vdbs_shadow_table_free. */
typedef struct vdbs_shadow_table {
    float *data;
    size_t floats;
    int lights;
} vdbs_shadow_table;

vdbs_status vdbs_shadow_table_init(vdbs_shadow_table *table, int lights, vdbs_error *err);
void vdbs_shadow_table_free(vdbs_shadow_table *table);

/* Light k's map: res x res depths along frame->w from the plane through frame->origin,
 * row 0 at -v (as glReadPixels returns a framebuffer); VDBS_NO_OCCLUDER where no occluder.
 * bias in world units. */
vdbs_status vdbs_shadow_table_set_sun(vdbs_shadow_table *table, int k,
                                      const vdbs_shadow_sun_frame *frame, int res,
                                      const float *depths, double bias, vdbs_error *err);
/* Light k's cube: faces f = 2 axis + (negative), each res x res distances from `position`
 * (vs_shadow.h for the face coordinates). */
vdbs_status vdbs_shadow_table_set_cube(vdbs_shadow_table *table, int k, const double position[3],
                                       int res, const float *distances, double bias,
                                       vdbs_error *err);

/* The kernels' visibility (vs_shadow_visibility) on the C path, for tests. */
float vdbs_shadow_visibility(const vdbs_shadow_table *table, int k, const double p[3]);

#define VDBS_NO_OCCLUDER 1.0e30f

#ifdef __cplusplus
}
#endif

#endif
