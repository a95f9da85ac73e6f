/* The ray-march render's engine (shaders/vs_render.h, one text for C and GLSL): the
 * kernel's render table and grid buffer, and a session that keeps everything but the
 * camera between pictures (the viewer; `render` draws one picture through
 * vdbs_render_march, render.h), with the viewer's interleaved sampling, gather pass,
 * backdrop of solid occluders and fog. */
#ifndef VDBSCATTER_MARCH_SESSION_H
#define VDBSCATTER_MARCH_SESSION_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/image.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/litvdb.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

struct vdbs_fog;

/* The viewer's homogeneous fog over a picture (shaders/vs_fogpass.h). */
typedef struct vdbs_march_fog {
    const struct vdbs_fog *fog; /* tables (fog.h) of the fog's sigma_t and g, albedo 1 */
    double box_lo[3], box_hi[3];
    double albedo[3];
    int steps; /* shadow-map tests along a ray; 0: 64 */
} vdbs_march_fog;

typedef struct vdbs_march_options {
    int sky_directions;      /* quadrature directions for the sky's S1 (>= 1) */
    float step_voxels;       /* camera-ray segment length in voxels (> 0; quality knob) */
    vdbs_progress *progress; /* may be NULL; counts finished pixels */
    /* GPU only: units of work (marches) per pixel and dispatch; 0 = chosen from the grid
     * size so that a dispatch stays within llvmpipe's loop limit. Tests set it to check
     * the resumption (1) and the limit detection (huge). */
    int gpu_units;
    /* S1 toward the lights: 0 from light grids (lightgrid.h) built once per call, one lookup
     * per light and sky ordinate per camera sample; 1 by the exact march (the oracle). */
    int s1_march;
    int s1_oversample; /* light-grid oversampling; 0 = the default */
    /* 1: S1 from the lit VDB's stored depths (vdbs_lit_grids.depth, one per light of the
     * scene's light table) instead of light grids swept here; ignored without them. Only
     * vdbs_march_session_create reads it: a new scene is swept (vdbs_march_session_set_scene). */
    int stored_depths;
    /* The viewer's knobs (0 for `render`): interleaved sampling over M x M pixel blocks
     * (2..VDBS_MAX_INTERLEAVE; 0 or 1 off): every pixel evaluates S on 1/M^2 of the
     * segments, its own phase (shaders/vs_render.h), and the gather pass
     * (vdbs_render_gather) sums the phases back; and which terms S holds. */
    int interleave;
    int no_single;   /* 1: no S1 (multiple scattering only) */
    int no_multiple; /* 1: no Sms (single scattering only) */
    /* The viewer's solid occluders seen from the camera: per pixel 4 floats (world distance
     * along the ray to the first surface, or VDBS_NO_SURFACE; the surface's radiance rgb).
     * The ray stops there and sees the surface instead of the background. NULL: none. */
    const float *backdrop;
    /* A homogeneous fog composited over the picture, its light shafts carved by the
     * session's shadow maps. NULL: none. */
    const vdbs_march_fog *fog;
    /* Filled by vdbs_render_march when not NULL. */
    struct vdbs_render_stats *stats;
} vdbs_march_options;

/* What a march render cost: the light grids' sizes and the time of each stage. */
typedef struct vdbs_render_stats {
    vdbs_light_grid_stats grids; /* zero with s1_march */
    double seconds_march;        /* the camera rays (with lookups or light marches) */
} vdbs_render_stats;

/* The kernel's render table (4 floats per entry, layout in shaders/vs_render.h), *data
 * malloc'd. ms may be NULL. Errors: bad options, grids beyond the 2^36-byte offset range. */
vdbs_status vdbs_render_table(const vdbs_volume *volume, const vdbs_lit_grids *ms,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              float **data, size_t *entries, vdbs_error *err);

/* The buffer both paths read: the density grid at byte 0 followed by ms, l1x, l1y, l1z
 * (when set) and the stored depths (grids may be NULL). When there are none of these,
 * *buffer is volume->nano and *owned is 0; otherwise a new allocation that the caller
 * frees. */
vdbs_status vdbs_render_buffer(const vdbs_volume *volume, const vdbs_lit_grids *ms,
                               uint32_t **buffer, size_t *size, int *owned, vdbs_error *err);

#define VDBS_MAX_INTERLEAVE 4
/* A backdrop distance that means "no surface on this pixel" (shaders' VS_T_INFINITE). */
#define VDBS_NO_SURFACE 1.0e30f

/* What a march session allocates for a picture of `pixels` beside its light grids
 * (vdbs_light_grids_estimate, all lights at once): the copy of the grids into one buffer
 * (vdbs_render_buffer), the stored depths' headers, and the interleaved gather's two
 * pictures. */
int64_t vdbs_march_session_bytes(const vdbs_volume *volume, const vdbs_lit_grids *ms,
                                 int64_t pixels);

/* A render that keeps everything but the camera between pictures (the viewer): the grids,
 * the light table and the light grids are built once, and on the GPU they stay resident.
 * volume and ms must outlive the session. */
typedef struct vdbs_march_session vdbs_march_session;

/* options: sky_directions, s1_march, s1_oversample and stats (light grids) are read here. */
vdbs_status vdbs_march_session_create(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_lit_grids *ms, const vdbs_scene *scene,
                                      const vdbs_march_options *options, vdbs_march_session **out,
                                      vdbs_error *err);
/* The occluders' shadow maps (shaders/vs_shadow.h layout; entry k for the light table's
 * direct light k, i.e. the scene's suns and point lights in order), which darken S1 toward
 * each direct light. The table is the caller's and must stay unchanged until the next call
 * (on the GPU it is uploaded once). NULL: no occluders. */
void vdbs_march_session_set_shadows(vdbs_march_session *session, const float *table, size_t floats);
/* The session's tables in the kernels' layouts, for the viewer's surface shading (lit
 * through the volume's light grids); valid until the next vdbs_march_session_set_scene. */
typedef struct vdbs_march_tables {
    const float *lights; /* shaders/vs_lights.h */
    size_t light_floats;
    const float *medium; /* shaders/vs_medium.h */
    size_t medium_floats;
    const uint32_t *light_grids; /* shaders/vs_lightgrid.h, one grid per direct light first;
                                    NULL with s1_march */
    size_t light_grid_words;
} vdbs_march_tables;
void vdbs_march_session_tables(const vdbs_march_session *session, vdbs_march_tables *out);
/* New lights or medium (a moved sun): the light table and light grids are rebuilt, by
 * sweeping (a lit VDB's stored depths no longer apply). */
vdbs_status vdbs_march_session_set_scene(vdbs_march_session *session, const vdbs_scene *scene,
                                         vdbs_error *err);
/* New values of the ms grids (live multiple scattering, inet_live.h): ms and ms_l1[0..2]
 * (l1x, l1y, l1z), 3 floats per output voxel as a bake writes them, into the session's copy
 * of the grids, on their topology (a voxel where a grid has no leaf keeps its value); on the
 * GPU the copy is uploaded again at the next draw, as a new resident input. The caller's
 * grids given to create are not changed. Errors (VDBS_ERR_INPUT): a session without ms
 * grids; out of memory the first time (the voxels' addresses). */
vdbs_status vdbs_march_session_set_ms(vdbs_march_session *session, const float *ms,
                                      float *const ms_l1[3], vdbs_error *err);
/* One picture, as vdbs_render_march; options: step_voxels, the viewer's knobs, gpu_units,
 * progress and stats (the march's time). */
vdbs_status vdbs_march_session_draw(vdbs_march_session *session, const vdbs_camera_frame *frame,
                                    const vdbs_march_options *options, vdbs_image *image,
                                    vdbs_error *err);
void vdbs_march_session_destroy(vdbs_march_session *session);

/* Interleaved sampling's gather (shaders/vs_gather.h) in place on image->rgb: a box filter
 * of `block` pixels across, then down, on the runner's backend. block <= 1: nothing. */
vdbs_status vdbs_render_gather(vdbs_runner *runner, vdbs_image *image, int block, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
