/* The light table: a scene's lights resolved once against a volume. Suns and point lights
 * get their world and index-space geometry; a sky gets its ordinates (directions and
 * solid-angle weights), one per propagation grid of the solvers that need them. The single
 * pass, the render march and the reference all read this one table: the kernels its packed
 * float layout (shaders/vs_lights.h), the C-only reference its double fields. */
#ifndef VDBSCATTER_LIGHTS_H
#define VDBSCATTER_LIGHTS_H

#include <stddef.h>

#include "vdbscatter/envmap.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A sun or point light, resolved. */
typedef struct vdbs_direct_light {
    vdbs_light_type type; /* VDBS_LIGHT_SUN or VDBS_LIGHT_POINT */
    double world[3];      /* sun: unit direction of travel; point: world position */
    double index[3];      /* sun: index image of a unit world step towards it; point: index
                             position */
    double color[3];      /* sun: irradiance W/m^2; point: intensity W/sr */
} vdbs_direct_light;

/* A sky direction of the quadrature: the sky seen towards `world` with `weight` sr. */
typedef struct vdbs_sky_ordinate {
    double world[3]; /* unit, towards the sky */
    double index[3]; /* index image of a unit world step towards the sky */
    double weight;   /* solid angle; the weights sum to 4 pi */
    double radiance[3];
} vdbs_sky_ordinate;

typedef struct vdbs_light_table {
    vdbs_direct_light *direct; /* suns and points, in scene order */
    int direct_count;
    vdbs_sky_ordinate *ordinates; /* empty without a sky or when none were asked for */
    int ordinate_count;
    int has_sky;
    double sky[3];    /* constant sky radiance: the sum of the env colours (background) */
    vdbs_envmap *env; /* the scene's lat-long map (scaled), or NULL; its ordinates are
                         importance-sampled (envmap.h) and carry sky[] on top */
    char env_file[VDBS_PATH_MAX];
    double min_distance; /* point lights' 1/r^2 is clamped at this world distance */
    float *packed;       /* the kernels' layout (shaders/vs_lights.h), 4 floats an entry */
    size_t packed_entries;
} vdbs_light_table;

typedef struct vdbs_lights_desc {
    int sky_ordinates; /* quadrature directions for a sky; 0: none (the reference samples
                          the sky itself) */
    /* A map's ordinates are drawn from its luminance times this map's first channel (a
     * lat-long importance, pop.h --pop-importance); NULL: the luminance alone. A constant sky
     * keeps its even directions. */
    const vdbs_envmap *importance;
    /* 1: a compact bright region of the map (vdbs_envmap_find_sun) becomes one ordinate of its
     * whole power and the others sample the rest (POP: ordinates on one small sun are the same
     * grid many times). */
    int split_sun;
} vdbs_lights_desc;

/* Resolves the scene's lights for the volume. Errors: an environment map that cannot be
 * used (envmap.h) or a second one, a zero sun direction (VDBS_ERR_INPUT), out of memory. On
 * error the table is empty. */
vdbs_status vdbs_lights_build(const vdbs_volume *volume, const vdbs_scene *scene,
                              const vdbs_lights_desc *desc, vdbs_light_table *table,
                              vdbs_error *err);
void vdbs_lights_free(vdbs_light_table *table);

/* (Re)writes table->packed from the other fields, e.g. after a caller kept only some of the
 * lights. */
vdbs_status vdbs_lights_pack(vdbs_light_table *table, vdbs_error *err);

/* Light `light` of the table (the direct lights, then the sky ordinates, as the kernels number
 * them) as it arrives at the world point p, before attenuation: its colour (a sun's
 * irradiance, a point's intensity over r^2 with r clamped at min_distance, an ordinate's
 * radiance times its solid angle) and its unit direction of travel. */
void vdbs_lights_arrival(const vdbs_light_table *table, int light, const double p[3],
                         double color[3], double travel[3]);

#ifdef __cplusplus
}
#endif

#endif
