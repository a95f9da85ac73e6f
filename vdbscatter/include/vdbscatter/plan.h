/* The planner behind `bake --method auto --tolerance E`: the scene measured on its volume
 * before any solve (features), each method and quality's error and cost predicted from a
 * table of measurements on the calibration set (bench/bench_calibrate.py writes them,
 * scripts/gen_plan_table.py compiles them into plan_table.h), and the cheapest plan whose
 * predicted image relative RMSE is within E: the method, its quality, and the lights too
 * weak to matter. docs/planner.md has the model and what it was measured to do. */
#ifndef VDBSCATTER_PLAN_H
#define VDBSCATTER_PLAN_H

#include "vdbscatter/quality.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What the planner knows of a scene. */
typedef struct vdbs_plan_features {
    double mean_depth; /* mean optical depth through the volume at the scene's scale */
    double albedo;     /* mean over R, G, B */
    double g;
    double ms_to_ss;        /* estimated multiple / single scattered power (advice.h) */
    double active_voxels;   /* the output voxels the solvers write */
    double active_fraction; /* active voxels / voxels of the support box */
    double voxel_mfp;       /* mean voxel length / mean free path at the mean density */
    double sky_share;       /* the sky's share of the power reaching the medium */
    double point_share;     /* the point lights' */
    double sky_variation;   /* relative spread of the sky's radiance over its ordinates */
    double light_share[VDBS_MAX_LIGHTS]; /* per scene light, in scene order */
    int light_count;
} vdbs_plan_features;

/* One method at one quality, predicted. */
typedef struct vdbs_plan_candidate {
    const char *method;
    int quality;    /* level, quality.h */
    double error;   /* predicted image relative RMSE */
    double seconds; /* predicted solve seconds on the C path: the solver entry's cost hint
                       times the active voxels */
    double spread;  /* the prediction's standard deviation in log error: error is the
                       predicted median times e^spread */
} vdbs_plan_candidate;

#define VDBS_PLAN_MAX_CANDIDATES 32

typedef struct vdbs_plan {
    double tolerance;
    int reachable;              /* 0: no candidate is predicted within the tolerance */
    vdbs_plan_candidate chosen; /* the cheapest within it, else the most accurate */
    int skip[VDBS_MAX_LIGHTS];  /* 1: the light is left out */
    int skipped;
    double skipped_share; /* the power share of the lights left out */
    vdbs_plan_candidate candidates[VDBS_PLAN_MAX_CANDIDATES];
    int candidate_count;
    int calibration_scenes; /* scenes of the table the prediction came from */
    char nearest[32];       /* the calibration scene most like this one */
} vdbs_plan;

/* Measures the scene on the volume (the density scale as resolved). Errors: the lights'
 * (an env map that cannot be read), out of memory. */
vdbs_status vdbs_plan_measure(const vdbs_scene *scene, const vdbs_volume *volume,
                              vdbs_plan_features *features, vdbs_error *err);

/* What to plan for; zero-initialised means the defaults. */
typedef struct vdbs_plan_desc {
    double tolerance;      /* in (0, 1); 0: 0.1 */
    const char *leave_out; /* NULL, or a calibration scene predicted as if it were not in the
                              table: the planner measured on a scene it has not seen */
} vdbs_plan_desc;

/* The plan. Errors: a tolerance of 1 or more, a leave_out that is not a calibration scene.
 * An unreachable tolerance gives reachable 0 with the most accurate candidate as `chosen`. */
vdbs_status vdbs_plan_make(const vdbs_plan_features *features, const vdbs_plan_desc *desc,
                           vdbs_plan *plan, vdbs_error *err);

/* Sets the chosen method and quality on the scene and removes the skipped lights. */
vdbs_status vdbs_plan_apply(const vdbs_plan *plan, vdbs_scene *scene, vdbs_error *err);

/* The plan and features as JSON text (the bake report's "plan", the lit VDB's
 * vdbscatter_plan); free() it. NULL when out of memory. */
char *vdbs_plan_json(const vdbs_plan *plan, const vdbs_plan_features *features);

#ifdef __cplusplus
}
#endif

#endif
