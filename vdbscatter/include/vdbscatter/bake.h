/* `bake`: density VDB in, lit VDB out (docs/lit-vdb.md). */
#ifndef VDBSCATTER_BAKE_H
#define VDBSCATTER_BAKE_H

#include "vdbscatter/advice.h"
#include "vdbscatter/cancel.h"
#include "vdbscatter/lightgrid.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/plan.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/single.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/status.h"
#include "vdbscatter/volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What a lit VDB stores beyond radiance and the multiple scattering (docs/lit-vdb.md). */
typedef enum vdbs_bake_store {
    VDBS_STORE_DEFAULT = 0, /* lights */
    VDBS_STORE_LIGHTS,      /* the optical depth toward every light and sky ordinate */
    VDBS_STORE_NONE         /* nothing more: renders relight the single scattering */
} vdbs_bake_store;

#define VDBS_BAKE_EXTRA_META_MAX 4

typedef struct vdbs_bake_options {
    const char *input;       /* density VDB; scene->volume_file when NULL */
    const char *output;      /* lit VDB */
    const vdbs_scene *scene; /* validated (lights may be none: an input error) */
    vdbs_backend backend;
    int s1_march;          /* single scattering by the exact march per voxel and light instead of
                              light grids (lightgrid.h; the default) */
    int s1_oversample;     /* light-grid samples per smallest voxel; 0 = the default */
    double s1_sky_spacing; /* sky ordinates' light-grid spacing (lightgrid.h sky_spacing) */
    int from_levelset;
    int half;
    vdbs_bake_store store;
    int progress; /* show progress on stderr */
    /* For a solver with state (solver.h; svd: the radiance moments, grids svd_m0000 ...):
     * write it into the lit VDB with keep_state, start from a lit VDB's with warm_start */
    int keep_state;
    const char *warm_start;
    vdbs_warn_fn warn;
    void *warn_user;
    /* > 0: --method auto --tolerance E: the planner (plan.h) picks the method, quality and
     * the lights worth baking for an image relative RMSE of E, on the volume before any
     * solve; an E it predicts out of reach is VDBS_ERR_INPUT naming the best it can do. The
     * scene's method and quality are replaced. */
    double tolerance;
    int dry_run; /* with tolerance: plan, fill the report's plan, solve and write nothing */
    /* With dry_run: plan as if this calibration scene were not in the planner's table
     * (vdbs_plan_desc.leave_out), to measure the planner on scenes it has not seen. */
    const char *plan_leave_out;
    /* Polled between stages and in the solvers' loops (cancel.h): once set, the bake stops
     * with VDBS_ERR_CANCELLED and leaves no temporary file; the output is the old file, or
     * the complete new one when the flag came after the rename. NULL: never. */
    const vdbs_cancel *cancel;
    /* Bytes the bake may hold (memory.h): a plan whose estimate, added to what the process
     * holds once the volume is loaded, exceeds it is VDBS_ERR_INPUT before the solve's
     * allocations, naming --max-memory. 0: vdbs_memory_default_limit(); < 0: no limit. */
    int64_t max_memory;
    /* More string metadata for the lit VDB (a sequence's frame, rate and hash), at most
     * VDBS_BAKE_EXTRA_META_MAX. */
    const vdbio_meta *extra_meta;
    int extra_meta_count;
} vdbs_bake_options;

typedef struct vdbs_bake_report {
    char backend[16];   /* "cpu" or "gpu" */
    char renderer[256]; /* GL renderer for gpu, "C (OpenMP, N threads)" for cpu */
    char grid[256];
    unsigned long long active_voxels;
    unsigned long long output_voxels;
    /* Bytes the solve moved between the host and the GPU (vdbs_runner_transfers; 0 on the C
     * path). */
    unsigned long long bytes_uploaded, bytes_read_back;
    int sky_directions;
    char quality_baked[8]; /* the quality whose settings were baked (vdbs_solver_quality) */
    char s1[8];            /* "march" or "grid" */
    int s1_oversample;     /* 0 for march */
    /* Light grids (grid only): sizes summed over the lights, and the time of each stage. */
    vdbs_light_grid_stats s1_grids;
    double seconds_s1_lookup;
    vdbs_s1_kind_stats s1_kinds[VDBS_S1_KINDS]; /* the same per kind of light */
    /* The solver's report block (its vdbs_solver.stats_size bytes: vdbs_pop_stats,
     * vdbs_fld_stats, vdbs_svd_stats ...), read through vdbs_bake_report_stats. */
    union {
        unsigned char bytes[VDBS_SOLVER_STATS_MAX];
        double align_double;
        long long align_long;
        void *align_pointer;
    } solver_stats;
    double seconds_load;
    double seconds_solve;
    double seconds_write;
    double seconds_total;
    float radiance_max[3]; /* per channel, over output voxels */
    /* The stored depths written (light_depth_*, then sky_depth_*; 0 with --store none). */
    int stored_direct, stored_sky;
    double density_scale; /* as used: auto:TAU resolved against the volume */
    vdbs_advice advice;   /* mean optical depth, estimated multiple/single ratio */
    /* With a tolerance: the plan and what it was made from (also in the lit VDB's
     * vdbscatter_plan). */
    int planned;
    vdbs_plan plan;
    vdbs_plan_features plan_features;
    /* Memory (docs/robustness.md "Bounded memory"): the limit checked (0: none), the resident
     * set once the volume was loaded, the estimate of what the bake adds to it by part, and
     * each stage's peak resident set (VmHWM; each stage's own where Linux lets the peak be
     * reset, peak_per_stage 1, else the process's so far). */
    int64_t memory_limit, memory_baseline;
    vdbs_memory_estimate memory_estimate;
    int64_t peak_load, peak_solve, peak_write;
    int peak_per_stage;
} vdbs_bake_report;

vdbs_status vdbs_bake(const vdbs_bake_options *options, vdbs_bake_report *report, vdbs_error *err);

/* The solver's stats in a report (e.g. a const vdbs_svd_stats * for --method svd). */
const void *vdbs_bake_report_stats(const vdbs_bake_report *report);

/* The solve of a bake without the files: the scene's solver on a volume already in memory,
 * into the caller's arrays of 3 floats per output voxel (zeroed; ms_l1 entries may all point
 * to ms for a solver without multiple scattering). options->input and output are not read.
 * For tests and benches that compare the solvers' fields with oracles. */
vdbs_status vdbs_bake_volume(const vdbs_bake_options *options, const vdbs_volume *volume,
                             float *radiance, float *ms, float *const ms_l1[3],
                             vdbs_bake_report *report, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
