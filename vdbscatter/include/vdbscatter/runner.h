/* The kernel runner: the one seam between the solvers and the two backends. The backend is
 * resolved once (auto: a hardware GPU through EGL, else the C path); every kernel then runs
 * through one entry point, either as an OpenMP loop over its items in C or as compute-shader
 * dispatches. On the GPU the runner owns what every shader needs the same way: pass splitting
 * under llvmpipe's loop limit with a canary check and retry (see shaders/vs_pass.h for why),
 * state ping-pong between dispatches, per-iteration reductions and progress.
 *
 * Two shapes of kernel:
 * - run: every item has a sequence of units (marches); the GPU runs them in passes of
 *   `units_per_dispatch` units per item, keeping each item's state between passes;
 * - iterate: every iteration is one step over all items, reading the previous iteration's
 *   state and writing the next, followed by a reduction (residual, remaining energy) that
 *   stops the loop at a tolerance or an iteration count. Propagation solvers use this; with
 *   `in_place` the steps share one state and run in order: a sweep in dependency order
 *   (plane after plane). */
#ifndef VDBSCATTER_KERNEL_H
#define VDBSCATTER_KERNEL_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/gpu.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbs_backend {
    VDBS_BACKEND_AUTO = 0, /* a hardware GPU if EGL finds one, else the C path */
    VDBS_BACKEND_CPU = 1,
    VDBS_BACKEND_GPU = 2
} vdbs_backend;

/* Parses "auto", "cpu" or "gpu" (VDBS_ERR_INPUT naming --backend otherwise). */
vdbs_status vdbs_backend_parse(const char *text, vdbs_backend *backend, vdbs_error *err);

typedef struct vdbs_runner vdbs_runner;

/* Zero-initialise; 0 means "choose the default". */
typedef struct vdbs_runner_desc {
    vdbs_backend backend; /* default auto */
    /* GPU: run on the GL context current on the calling thread (a window's) instead of a
     * new headless EGL one. */
    int current_context;
} vdbs_runner_desc;

/* Resolves the backend and, for the GPU, creates the GL context (current on the calling
 * thread until destroy). desc may be NULL. Errors: no GL context for --backend gpu. */
vdbs_status vdbs_runner_create(const vdbs_runner_desc *desc, vdbs_runner **out, vdbs_error *err);
void vdbs_runner_destroy(vdbs_runner *runner);
/* VDBS_BACKEND_CPU or VDBS_BACKEND_GPU. */
vdbs_backend vdbs_runner_backend(const vdbs_runner *runner);
/* "cpu" or "gpu". */
const char *vdbs_runner_backend_name(const vdbs_runner *runner);
/* The GL renderer, or "C (OpenMP, N threads)". */
const char *vdbs_runner_device(const vdbs_runner *runner);
/* NULL on the C path. */
vdbs_gpu *vdbs_runner_gpu(vdbs_runner *runner);
/* A fresh id for a resident input (vdbs_kernel_input.resident), never 0. */
uint64_t vdbs_runner_resident_id(vdbs_runner *runner);
/* Frees the GPU copy kept under id (nothing on the C path or for an unknown id). */
void vdbs_runner_release(vdbs_runner *runner, uint64_t id);

/* Bytes the runner has moved between the host and the GPU since it was created. Uploads:
 * kernel inputs, initial states and every dispatch's control words; read-backs: final states,
 * outputs, control words and reduction partials. The C path moves nothing (its kernels read
 * the caller's arrays): all 0. */
typedef struct vdbs_runner_transfer {
    unsigned long long uploaded;
    unsigned long long read_back;
    unsigned long long resident_uploaded; /* of uploaded: resident inputs' (kept under an id) */
} vdbs_runner_transfer;

vdbs_runner_transfer vdbs_runner_transfers(const vdbs_runner *runner);

/* A read-only input of a shader, bound at its index in vdbs_kernel_desc.inputs. */
typedef struct vdbs_kernel_input {
    const void *data;
    size_t size; /* bytes; 0 = binding unused */
    /* 0: uploaded for this call only. Else an id from vdbs_runner_resident_id: the GPU keeps
     * the data under it and later calls with the same id and size upload nothing (a viewer's
     * grids, every frame). Give a new id (or release the old) when the data change. */
    uint64_t resident;
} vdbs_kernel_input;

#define VDBS_KERNEL_MAX_INPUTS 8

typedef enum vdbs_reduce {
    VDBS_REDUCE_SUM = 0,
    VDBS_REDUCE_MAX = 1,
    /* The caller wants no reduction (result.reduction 0, tolerance unused): the GPU reads
     * back no partials after each step. */
    VDBS_REDUCE_NONE = 2
} vdbs_reduce;

typedef struct vdbs_kernel_desc {
    uint64_t items;
    void *user; /* handed to the C functions */

    /* C path. run: every unit of items [begin, end). iterate: step `step` (the shader's
     * vs_pass_done()) of items [begin, end) from state_in to state_out; returns the chunk's
     * reduction. */
    void (*cpu_items)(void *user, uint64_t begin, uint64_t end);
    double (*cpu_step)(void *user, int step, const void *state_in, void *state_out, uint64_t begin,
                       uint64_t end);
    uint64_t cpu_chunk; /* items per OpenMP task; default 256 */

    /* GPU path: an embedded compute shader following shaders/vs_pass.h. */
    const char *shader;
    vdbs_kernel_input inputs[VDBS_KERNEL_MAX_INPUTS];
    size_t state_words;  /* 32-bit words of state per item; default 1 */
    size_t output_words; /* run: 32-bit words of output per item, read back into output */
    void *output;
    int units_per_dispatch; /* run: first guess; halved when a pass hits the loop limit;
                               default: all units in one pass */
    int total_units;        /* run: units per item when known, for progress; 0 = unknown */
    uint64_t gpu_chunk;     /* items per dispatch call; default: as many as the GPU allows */

    /* iterate */
    void *state;      /* state_items * state_words words: the initial state in, the final one out */
    int state_zeroed; /* the caller's initial state is all zeros: the GPU clears its copy
                         instead of uploading it */
    uint64_t state_items; /* items the state holds; default `items` (a sweep's steps each
                             cover a part of it) */
    int in_place;         /* every step reads and writes one state instead of ping-pong: a sweep in
                             dependency order, step s (vs_pass_done() in the shader) working on the
                             items that depend on step s - 1's */
    int max_iterations;   /* default 1 */
    double tolerance;     /* > 0: stop once the reduction is <= this; default 0: run them all */
    vdbs_reduce reduce;

    vdbs_progress *progress; /* may be NULL: run counts items, iterate counts iterations */
    /* Polled between chunks, dispatches and steps, as is progress->cancel: once set, the
     * call returns VDBS_ERR_CANCELLED with the outputs incomplete. NULL: never. */
    const vdbs_cancel *cancel;
} vdbs_kernel_desc;

typedef struct vdbs_kernel_result {
    int iterations;   /* iterate: steps run */
    double reduction; /* iterate: the last step's reduction */
    int dispatches;   /* GPU: passes or steps dispatched, retries included */
    int retries;      /* GPU: passes repeated with fewer units */
} vdbs_kernel_result;

/* result may be NULL. */
vdbs_status vdbs_kernel_run(vdbs_runner *runner, const vdbs_kernel_desc *desc,
                            vdbs_kernel_result *result, vdbs_error *err);
vdbs_status vdbs_kernel_iterate(vdbs_runner *runner, const vdbs_kernel_desc *desc,
                                vdbs_kernel_result *result, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
