/* Live multiple scattering on an illumination network (inet.h): the network, its links and the
 * phase matrix built once for a volume and medium, the first scattering E seeded per particle
 * for a set of lights, and the state kept between calls so that new lights start from the old
 * solution (a warm start) and a few sweeps a frame walk it to the new one. The viewer shows
 * the state of every frame (vdbs_inet_live_ms) while it converges.
 *
 * The cold solve is the bake's Jacobi iteration through the runner; a lit VDB's kept state
 * (inet.h's vdbs_inet_voxel_state) replaces it with a start from the stored radiance and warm
 * sweeps. The warm sweeps are
 * Gauss-Seidel line sweeps on the C path (the directions in turn, each direction's chains
 * walked downstream with the newest values), which reach the same fixed point in a few
 * sweeps where Jacobi needs tens.
 *
 * The network matches the bake's for the same volume, medium, quality and solver.inet_*
 * options (seed 0), but E comes from marching the transmittance from each particle to each
 * light rather than from the bake's S1 light grids, so the converged ms agrees with the baked
 * one up to the two first scatterings' difference. */
#ifndef VDBSCATTER_INET_LIVE_H
#define VDBSCATTER_INET_LIVE_H

#include <stdint.h>

#include "vdbscatter/inet.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Zero-initialise; 0 / NULL means the default. */
typedef struct vdbs_inet_live_desc {
    const vdbs_volume *volume; /* must outlive the object */
    /* lights, albedo, g, density_scale and solver.inet_* (copied; the lights are replaced by
     * vdbs_inet_live_set_lights, the medium stays) */
    const vdbs_scene *scene;
    const char *quality;     /* the bake's quality: the same presets; default the scene's,
                                else medium */
    vdbs_runner *runner;     /* the cold solve's (the viewer's, a GPU in its GL context);
                                NULL: a C-path runner of the object's own */
    vdbs_progress *progress; /* the cold solve's; may be NULL */
    /* A lit VDB holding an inet --keep-state (inet.h's vdbs_inet_voxel_state; opened with at
     * least its inet_r grids), or NULL. When its D is the network's, the opening solve starts
     * every particle from its voxel's stored radiance and runs warm line sweeps to the
     * quality's residual instead of the cold solve; else it solves cold. */
    const vdbio_lit *state;
    const char *state_path; /* the file's name, for messages */
} vdbs_inet_live_desc;

/* How the opening solve went. */
typedef struct vdbs_inet_live_opening {
    int from_state; /* 1: started from desc.state and warm line sweeps; 0: the cold solve */
    int sweeps;     /* the opening solve's sweeps (line sweeps from a state, else Jacobi) */
} vdbs_inet_live_opening;

typedef struct vdbs_inet_live vdbs_inet_live;

typedef struct vdbs_inet_live_status {
    int sweeps;       /* since the last re-seed (create or set_lights) */
    double change;    /* the last sweep's total change over the first scattering's total */
    double tolerance; /* the quality's residual: converged once change <= tolerance */
    int converged;
} vdbs_inet_live_status;

/* Builds the network, links and phase matrix, seeds E for the scene's lights and solves until
 * the quality's residual (or the iteration cap): from zero, or from desc.state. Errors: no
 * density, a bad light (lights.h), the runner's, a state file's grids unreadable, out of
 * memory. */
vdbs_status vdbs_inet_live_create(const vdbs_inet_live_desc *desc, vdbs_inet_live **out,
                                  vdbs_error *err);
/* Re-seeds E for the scene's lights (only its lights are read) and keeps the state: the next
 * sweeps start from the old solution. The sky's E is kept when its ordinates are unchanged,
 * so a moved sun costs N transmittance marches per direct light. */
vdbs_status vdbs_inet_live_set_lights(vdbs_inet_live *live, const vdbs_scene *scene,
                                      vdbs_error *err);
/* Runs `sweeps` warm line sweeps (0: none, only the status), stopping once converged (a sweep
 * changed the state by at most the residual of the first scattering's total). status may be
 * NULL. Errors: none yet (the sweeps are the C path's). */
vdbs_status vdbs_inet_live_sweep(vdbs_inet_live *live, int sweeps, vdbs_inet_live_status *status,
                                 vdbs_error *err);
/* The state as ms and ms_l1 on the output voxels (3 floats per voxel each; zeroed, then filled
 * as vdbs_inet_to_voxels). Errors: out of memory. */
vdbs_status vdbs_inet_live_ms(const vdbs_inet_live *live, float *ms, float *const ms_l1[3],
                              vdbs_error *err);
/* The problem (network, phase, emission) and the state (links then sinks, 3 floats a slot),
 * valid until the next call that changes them (tests compare with vdbs_inet_to_voxels). */
vdbs_inet_problem vdbs_inet_live_problem(const vdbs_inet_live *live);
const float *vdbs_inet_live_state(const vdbs_inet_live *live);
/* How the opening solve (vdbs_inet_live_create) started and how many sweeps it took. */
vdbs_inet_live_opening vdbs_inet_live_opened(const vdbs_inet_live *live);
void vdbs_inet_live_destroy(vdbs_inet_live *live);

#ifdef __cplusplus
}
#endif

#endif
