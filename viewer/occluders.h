/* The viewer's solid occluders on the GPU: their triangles (mesh.h) drawn into the shadow
 * maps of the lights (a sun's orthographic depth map, a point light's distance cube;
 * shadow.h assembles what the kernels read) and, from the camera, into the backdrop of
 * the render kernel: per pixel the distance to the first surface and its shaded radiance
 * (shaders/occluder_surface.frag). */
#ifndef VDBSCATTER_VIEWER_OCCLUDERS_H
#define VDBSCATTER_VIEWER_OCCLUDERS_H

#include "vdbscatter/camera.h"
#include "vdbscatter/fog.h"
#include "vdbscatter/march_session.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/shadow.h"
#include "vdbscatter/status.h"

typedef struct view_occluders {
    int count; /* occluders; 0: nothing to draw, no maps */
    unsigned vertex_array, vertex_buffer;
    int *first, *vertices; /* per occluder: its range in the buffer */
    float (*albedo)[3];
    double finite_lo[3], finite_hi[3]; /* bounds of every occluder but planes */
    int finite;                        /* 1 when those bounds hold something */
    unsigned sun_program, cube_program, surface_program;
    unsigned framebuffer, colour, depth; /* the render target, resized on demand */
    int target_width, target_height;
    float *pixels; /* read-back scratch */
    unsigned ssbo_lights, ssbo_shadows, ssbo_fog, ssbo_dummy, ssbo_medium, ssbo_light_grids;
    int with_light_grids;
    double world_to_index[3][4];
    const vdbs_march_fog *fog; /* the caller's, or NULL */
} view_occluders;

/* Needs a current GL 4.5 context. focus: where the planes' quads are centred; extent: the
 * volume's size (planes are drawn a few of it wide). */
vdbs_status view_occluders_init(view_occluders *o, const vdbs_scene *scene, const double focus[3],
                                double extent, vdbs_error *err);
void view_occluders_free(view_occluders *o);

/* Shadow maps of every sun and point light of `scene` (entry k for the k-th of them) over
 * the box [lo, hi] (the volume, fog and occluders), res texels across. */
vdbs_status view_occluders_shadow_maps(view_occluders *o, const vdbs_scene *scene,
                                       const double lo[3], const double hi[3], int res,
                                       vdbs_shadow_table *table, vdbs_error *err);

/* The fog the surfaces see, kept (it must outlive o) and its table uploaded once; NULL or
 * a fog without tables: none. */
void view_occluders_set_fog(view_occluders *o, const vdbs_march_fog *fog);

/* What the surfaces are lit through, uploaded once per light position: the session's light
 * table, medium and light grids (the volume's shadow on the surfaces) and the occluders'
 * shadow maps. world_to_index: the volume's. */
void view_occluders_set_lighting(view_occluders *o, const vdbs_march_tables *tables,
                                 const double world_to_index[3][4],
                                 const vdbs_shadow_table *shadows);

/* The backdrop of the picture of `frame`: 4 floats per pixel (distance, radiance rgb), row
 * 0 on top, VDBS_NO_SURFACE where no occluder is seen. */
vdbs_status view_occluders_backdrop(view_occluders *o, const vdbs_camera_frame *frame,
                                    float *backdrop, vdbs_error *err);

#endif
