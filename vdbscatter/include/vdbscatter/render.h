/* Pictures of a volume: `vdbs_render()` is the whole `render` job (open the input, merge a
 * lit VDB's scene with the caller's overrides, choose mode, grid and backend, render, write
 * the image, time the stages), beside `vdbs_bake()`. Its deterministic modes use the
 * ray-march kernel (shaders/vs_render.h, one text for C and GLSL): `single` (S1 of the
 * density volume) and `baked` (S1 exactly toward the camera plus Sms from a lit VDB's ms
 * and ms_l1* grids); `reference` is the Monte-Carlo path tracer (reference.h).
 *
 * Per pixel: L = integral T(0,t) sigma_s S(x, wo) dt + T_total L_background, the constant
 * env colour as background (black without env). */
#ifndef VDBSCATTER_RENDER_H
#define VDBSCATTER_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/cancel.h"
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

/* The presets of --quality (quality.h): sky directions 16 / 64 / 256 / 1024 and steps of
 * 1, 1/2, 1/4, 1/8 voxel for low / medium / high / ultra. Returns 0 for an unknown name. */
int vdbs_render_quality(const char *quality, vdbs_march_options *options);

/* The kernel's render table (4 floats per entry, layout in shaders/vs_render.h), *data
 * malloc'd. ms may be NULL. Errors: bad options, grids beyond the 2^36-byte offset range. */
vdbs_status vdbs_render_table(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              float **data, size_t *entries, vdbs_error *err);

/* The buffer both paths read: the density grid at byte 0 followed by ms, l1x, l1y, l1z
 * (when ms is not NULL and set). When there are no ms grids, *buffer is volume->nano and
 * *owned is 0; otherwise a new allocation that the caller frees. */
vdbs_status vdbs_render_buffer(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                               uint32_t **buffer, size_t *size, int *owned, vdbs_error *err);

/* Ray-marches frame->width x frame->height pixels into image->rgb, which the caller has
 * allocated with that size (image->se is left alone), on the runner's backend. ms NULL or
 * empty: single mode. The scene's lights are resolved once per call. On the GPU the rays
 * run in passes of options->gpu_units marches per pixel (vs_pass.h). Errors: an
 * environment map (only a constant env colour is supported), a zero sun direction. */
vdbs_status vdbs_render_march(vdbs_runner *runner, const vdbs_volume *volume,
                              const vdbs_ms_grids *ms, const vdbs_scene *scene,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              vdbs_image *image, vdbs_error *err);

#define VDBS_MAX_INTERLEAVE 4
/* A backdrop distance that means "no surface on this pixel" (shaders' VS_T_INFINITE). */
#define VDBS_NO_SURFACE 1.0e30f

/* A render that keeps everything but the camera between pictures (the viewer): the grids,
 * the light table and the light grids are built once, and on the GPU they stay resident.
 * volume and ms must outlive the session. */
typedef struct vdbs_march_session vdbs_march_session;

/* options: sky_directions, s1_march, s1_oversample and stats (light grids) are read here. */
vdbs_status vdbs_march_session_create(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_ms_grids *ms, const vdbs_scene *scene,
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
/* New lights or medium (a moved sun): the light table and light grids are rebuilt. */
vdbs_status vdbs_march_session_set_scene(vdbs_march_session *session, const vdbs_scene *scene,
                                         vdbs_error *err);
/* One picture, as vdbs_render_march; options: step_voxels, the viewer's knobs, gpu_units,
 * progress and stats (the march's time). */
vdbs_status vdbs_march_session_draw(vdbs_march_session *session, const vdbs_camera_frame *frame,
                                    const vdbs_march_options *options, vdbs_image *image,
                                    vdbs_error *err);
void vdbs_march_session_destroy(vdbs_march_session *session);

/* Interleaved sampling's gather (shaders/vs_gather.h) in place on image->rgb: a box filter
 * of `block` pixels across, then down, on the runner's backend. block <= 1: nothing. */
vdbs_status vdbs_render_gather(vdbs_runner *runner, vdbs_image *image, int block, vdbs_error *err);

typedef enum vdbs_render_mode {
    VDBS_RENDER_DEFAULT = 0, /* baked for a lit VDB, single otherwise */
    VDBS_RENDER_SINGLE,
    VDBS_RENDER_BAKED,
    VDBS_RENDER_REFERENCE
} vdbs_render_mode;

/* "single", "baked" or "reference" (NULL for the default). */
const char *vdbs_render_mode_name(vdbs_render_mode mode);

/* Which scene fields the caller set explicitly (command-line flags): for a lit VDB they
 * go on top of the scene it was baked with. */
enum {
    VDBS_SCENE_SET_DENSITY_SCALE = 1 << 0,
    VDBS_SCENE_SET_ALBEDO = 1 << 1,
    VDBS_SCENE_SET_G = 1 << 2,
    VDBS_SCENE_SET_QUALITY = 1 << 3,
    VDBS_SCENE_SET_LIGHTS = 1 << 4,
    VDBS_SCENE_SET_GRID = 1 << 5,
    VDBS_SCENE_SET_SKY_DIRECTIONS = 1 << 7,
    VDBS_SCENE_FROM_FILE = 1 << 6 /* a scene file was given: it replaces a baked scene */
};

/* Zero-initialise; 0 means "choose the default". */
typedef struct vdbs_render_desc {
    const char *input;       /* density or lit VDB; scene->volume_file when NULL */
    const char *output;      /* .exr or .png */
    const vdbs_scene *scene; /* the caller's scene (may have no lights for a lit VDB) */
    unsigned scene_set;      /* VDBS_SCENE_SET_* bits */
    vdbs_render_mode mode;
    vdbs_backend backend;      /* single/baked; reference always runs on the C path */
    const vdbs_camera *camera; /* NULL: the scene's camera, else a view of the whole volume */
    int width, height;         /* 0: the scene camera's size, else 640x480 */
    double exposure;           /* PNG only, EV */
    int gpu_units;             /* see vdbs_march_options */
    int s1_march;              /* single/baked: 1 marches to the lights (vdbs_march_options) */
    int s1_oversample;         /* light-grid oversampling; 0 = the default */
    /* reference mode */
    int spp;           /* default 64 (4 with time_limit) */
    double time_limit; /* seconds; 0 = one round of spp */
    int max_bounces;   /* default 1000 */
    uint64_t seed;     /* 0 is a seed like any other */
    int no_env_nee;    /* vdbs_reference_options.no_env_nee */
    int progress;      /* show progress on stderr */
    vdbs_warn_fn warn;
    void *warn_user;
    /* Polled between stages and in the render loops (cancel.h): once set, vdbs_render stops
     * with VDBS_ERR_CANCELLED and leaves no temporary image; the old picture stays unless
     * the new one was already renamed into place. NULL: never. */
    const vdbs_cancel *cancel;
} vdbs_render_desc;

typedef struct vdbs_render_report {
    const char *mode; /* "single", "baked" or "reference" */
    char backend[16];
    char renderer[256];
    char grid[256];
    char quality[32];
    int width, height;
    int spp; /* samples per pixel taken (1 for the march) */
    int sky_directions;
    float step_voxels;
    vdbs_camera camera;  /* as used */
    double camera_up[3]; /* the frame's up */
    double seconds_load, seconds_render, seconds_write, seconds_total;
    /* single/baked: "grid" or "march", the grids' oversampling (0 for march), their sizes,
     * and the render split into the sweeps and the camera rays */
    char s1[8];
    int s1_oversample;
    vdbs_render_stats march_stats;
} vdbs_render_report;

vdbs_status vdbs_render(const vdbs_render_desc *desc, vdbs_render_report *report, vdbs_error *err);

/* What a render works from, resolved once (the viewer keeps it open): the mode, the scene (a
 * lit VDB's baked scene with the caller's settings on top), the density, the ms grids
 * (baked mode), the camera (the desc's, the scene's or a view of the whole volume, with
 * the desc's size) and the quality's march options. */
typedef struct vdbs_render_input {
    vdbs_render_mode mode; /* never DEFAULT */
    int is_lit;
    char baked_method[32]; /* a lit VDB's bake method ("pop", ...); "" otherwise */
    vdbs_scene *scene;
    vdbs_volume volume;
    vdbs_ms_grids ms;
    vdbs_camera camera;
    vdbs_march_options march;
} vdbs_render_input;

/* desc->output is not read. Errors as vdbs_render's; on error *input is freed. */
vdbs_status vdbs_render_open(const vdbs_render_desc *desc, vdbs_render_input *input,
                             vdbs_error *err);
void vdbs_render_input_free(vdbs_render_input *input);

#ifdef __cplusplus
}
#endif

#endif
