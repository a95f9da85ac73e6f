#include "vdbscatter/runner.h"

#include <inttypes.h>
#include <omp.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "vs_pass.h"

#define DEFAULT_CPU_CHUNK 256u
/* The canary loop's trip count: any count > 1 shows a cut-short loop (it then runs once). */
#define CANARY_TRIPS 2u
#define MAX_UNITS 0x7fffffff

/* Programs are built once per runner (an interactive caller runs the same kernel every
 * frame); resident inputs stay on the GPU under their caller's id until released (the table
 * grows: a multigrid solve keeps a few per level). */
#define RUNNER_MAX_PROGRAMS 32
#define RUNNER_FIRST_RESIDENT 16

typedef struct runner_program {
    const char *shader; /* the embedded source's name: static storage */
    vdbs_gpu_program program;
} runner_program;

typedef struct runner_resident {
    uint64_t id; /* 0: free slot */
    size_t size;
    vdbs_gpu_buffer buffer;
} runner_resident;

struct vdbs_runner {
    vdbs_backend backend;
    vdbs_gpu *gpu;
    char device[256];
    runner_program programs[RUNNER_MAX_PROGRAMS];
    runner_resident *resident;
    int resident_slots;
    uint64_t next_resident_id;
    vdbs_runner_transfer transfer;
};

vdbs_status vdbs_backend_parse(const char *text, vdbs_backend *backend, vdbs_error *err)
{
    if (strcmp(text, "auto") == 0)
        *backend = VDBS_BACKEND_AUTO;
    else if (strcmp(text, "cpu") == 0)
        *backend = VDBS_BACKEND_CPU;
    else if (strcmp(text, "gpu") == 0)
        *backend = VDBS_BACKEND_GPU;
    else
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--backend: expected auto, cpu or gpu, got '%s'",
                              text);
    return VDBS_OK;
}

vdbs_status vdbs_runner_create(const vdbs_runner_desc *desc, vdbs_runner **out, vdbs_error *err)
{
    *out = NULL;
    vdbs_runner *r = calloc(1, sizeof *r);
    if (!r)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the kernel runner");
    r->backend = desc ? desc->backend : VDBS_BACKEND_AUTO;
    /* llvmpipe runs the same kernels 3-5x slower than the C path: auto takes real GPUs only. */
    if (r->backend == VDBS_BACKEND_AUTO)
        r->backend = vdbs_gpu_hardware_available() ? VDBS_BACKEND_GPU : VDBS_BACKEND_CPU;
    if (r->backend == VDBS_BACKEND_GPU) {
        vdbs_status st = desc && desc->current_context ? vdbs_gpu_adopt_current(&r->gpu, err)
                                                       : vdbs_gpu_create(&r->gpu, err);
        if (st != VDBS_OK) {
            free(r);
            return st;
        }
        snprintf(r->device, sizeof r->device, "%s", vdbs_gpu_get_info(r->gpu)->renderer);
    } else {
        snprintf(r->device, sizeof r->device, "C (OpenMP, %d threads)", omp_get_max_threads());
    }
    *out = r;
    return VDBS_OK;
}

void vdbs_runner_destroy(vdbs_runner *runner)
{
    if (!runner)
        return;
    if (runner->gpu) {
        for (int i = 0; i < RUNNER_MAX_PROGRAMS; ++i)
            vdbs_gpu_program_destroy(runner->gpu, runner->programs[i].program);
        for (int i = 0; i < runner->resident_slots; ++i)
            vdbs_gpu_buffer_destroy(runner->gpu, runner->resident[i].buffer);
        vdbs_gpu_destroy(runner->gpu);
    }
    free(runner->resident);
    free(runner);
}

uint64_t vdbs_runner_resident_id(vdbs_runner *runner)
{
    return ++runner->next_resident_id;
}

void vdbs_runner_release(vdbs_runner *runner, uint64_t id)
{
    for (int i = 0; id && i < runner->resident_slots; ++i)
        if (runner->resident[i].id == id) {
            vdbs_gpu_buffer_destroy(runner->gpu, runner->resident[i].buffer);
            memset(&runner->resident[i], 0, sizeof runner->resident[i]);
        }
}

vdbs_backend vdbs_runner_backend(const vdbs_runner *runner)
{
    return runner->backend;
}

const char *vdbs_runner_backend_name(const vdbs_runner *runner)
{
    return runner->backend == VDBS_BACKEND_GPU ? "gpu" : "cpu";
}

const char *vdbs_runner_device(const vdbs_runner *runner)
{
    return runner->device;
}

vdbs_gpu *vdbs_runner_gpu(vdbs_runner *runner)
{
    return runner->gpu;
}

vdbs_runner_transfer vdbs_runner_transfers(const vdbs_runner *runner)
{
    return runner->transfer;
}

/* ---- C path ---- */

static uint64_t cpu_chunk(const vdbs_kernel_desc *d)
{
    return d->cpu_chunk ? d->cpu_chunk : DEFAULT_CPU_CHUNK;
}

static int desc_cancelled(const vdbs_kernel_desc *d)
{
    return vdbs_cancelled(d->cancel) || vdbs_progress_cancelled(d->progress);
}

/* Whether it stopped for a cancel (the remaining chunks skipped: an OpenMP loop cannot break). */
static int cpu_run(const vdbs_kernel_desc *d)
{
    const uint64_t chunk = cpu_chunk(d);
    const int64_t chunks = (int64_t)((d->items + chunk - 1) / chunk);
    uint64_t done = 0;
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t c = 0; c < chunks; ++c) {
        if (desc_cancelled(d))
            continue;
        uint64_t begin = (uint64_t)c * chunk;
        uint64_t end = begin + chunk < d->items ? begin + chunk : d->items;
        d->cpu_items(d->user, begin, end);
        uint64_t now;
#pragma omp atomic capture
        now = done += end - begin;
        if (d->progress && omp_get_thread_num() == 0)
            vdbs_progress_update(d->progress, now);
    }
    return desc_cancelled(d);
}

/* Bytes of the state an iterate step reads or writes. */
static size_t state_bytes(const vdbs_kernel_desc *d)
{
    uint64_t items = d->state_items ? d->state_items : d->items;
    return (d->state_words ? d->state_words : 1) * 4u * (size_t)items;
}

/* Records step `it`'s reduction; whether the tolerance stops the loop. */
static int step_done(const vdbs_kernel_desc *d, int it, double reduction,
                     vdbs_kernel_result *result)
{
    result->iterations = it + 1;
    result->reduction = reduction;
    if (d->progress)
        vdbs_progress_update(d->progress, (uint64_t)it + 1);
    return d->tolerance > 0.0 && d->reduce != VDBS_REDUCE_NONE && reduction <= d->tolerance;
}

static double combine(vdbs_reduce reduce, double a, double b)
{
    return reduce == VDBS_REDUCE_MAX ? (a > b ? a : b) : a + b;
}

/* The steps of an iterate loop share one team, and each step ends at this barrier instead of
 * OpenMP's: a thread that waits spins briefly, then yields its core, so that a thread of ours
 * or another process's that the core owes time to runs. OpenMP's barriers spin for much longer
 * before they sleep: on cores shared with another busy process, a solver of thousands of short
 * steps (SVD's wavefront planes) then waits at every step for a thread that is not running
 * (docs/farm.md "Cores shared with other work"). */
#define STEP_SPINS 2000
/* Then, past this many yields (a long step: milliseconds), it sleeps between looks instead of
 * keeping a core busy. */
#define STEP_YIELDS 2000
#define STEP_NAP_NS 50000L

typedef struct step_team {
    const vdbs_kernel_desc *d;
    int64_t chunks;
    uint64_t chunk;
    double *partials;
    void *in, *out;
    int max_iterations;
    atomic_int arrived, generation;
    atomic_llong next[2]; /* the next chunk to take, by the step's parity */
    int stop;             /* 1: done, 2: cancelled; written by the calling thread */
    vdbs_kernel_result *result;
} step_team;

/* Between two steps, on the calling thread (progress is per thread): the reduction, the swap,
 * the stop. */
static void step_end(step_team *t, int it)
{
    const vdbs_kernel_desc *d = t->d;
    /* In chunk order, so that the reduction does not depend on the thread count. */
    double reduction = 0.0;
    for (int64_t c = 0; c < t->chunks && d->reduce != VDBS_REDUCE_NONE; ++c)
        reduction = combine(d->reduce, reduction, t->partials[c]);
    void *swap = t->in;
    t->in = t->out;
    t->out = swap;
    if (step_done(d, it, reduction, t->result))
        t->stop = 1;
    else if (desc_cancelled(d))
        t->stop = 2;
    /* This step's counter is next used two steps on; every thread has left it. */
    atomic_store(&t->next[it & 1], 0);
}

/* Spins, then yields, then naps, until *v == value. */
static void step_wait(atomic_int *v, int value)
{
    const int nap_after = STEP_SPINS + STEP_YIELDS;
    for (int looks = 0; atomic_load(v) != value; looks += looks < nap_after) {
        if (looks >= nap_after) {
            struct timespec nap = {0, STEP_NAP_NS};
            nanosleep(&nap, NULL);
        } else if (looks >= STEP_SPINS)
            sched_yield();
    }
}

/* The calling thread (OpenMP's thread 0) waits for the others, ends the step and lets them on;
 * the others wait for the next generation (it cannot move twice: the next needs them). */
static void step_barrier(step_team *t, int it, int caller)
{
    if (caller) {
        step_wait(&t->arrived, omp_get_num_threads() - 1);
        step_end(t, it);
        atomic_store(&t->arrived, 0);
        atomic_fetch_add(&t->generation, 1);
        return;
    }
    const int generation = atomic_load(&t->generation);
    atomic_fetch_add(&t->arrived, 1);
    step_wait(&t->generation, generation + 1);
}

static void step_team_run(step_team *t)
{
    const vdbs_kernel_desc *d = t->d;
    const int caller = omp_get_thread_num() == 0;
    for (int it = 0; it < t->max_iterations; ++it) {
        for (int64_t c; (c = atomic_fetch_add(&t->next[it & 1], 1)) < t->chunks;) {
            uint64_t begin = (uint64_t)c * t->chunk;
            uint64_t end = begin + t->chunk < d->items ? begin + t->chunk : d->items;
            t->partials[c] = d->cpu_step(d->user, it, t->in, t->out, begin, end);
        }
        step_barrier(t, it, caller);
        if (t->stop)
            return;
    }
}

static vdbs_status cpu_iterate(const vdbs_kernel_desc *d, int max_iterations,
                               vdbs_kernel_result *result, vdbs_error *err)
{
    const uint64_t chunk = cpu_chunk(d);
    const int64_t chunks = (int64_t)((d->items + chunk - 1) / chunk);
    const size_t bytes = state_bytes(d);
    void *other = d->in_place ? NULL : malloc(bytes ? bytes : 1);
    double *partials = malloc(sizeof *partials * (size_t)(chunks > 0 ? chunks : 1));
    if ((!other && !d->in_place) || !partials) {
        free(other);
        free(partials);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu bytes of state", bytes);
    }
    /* In place, in and out stay the same buffer. */
    step_team t = {.d = d,
                   .chunks = chunks,
                   .chunk = chunk,
                   .partials = partials,
                   .in = d->state,
                   .out = d->in_place ? d->state : other,
                   .max_iterations = max_iterations,
                   .result = result};
    atomic_init(&t.arrived, 0);
    atomic_init(&t.generation, 0);
    atomic_init(&t.next[0], 0);
    atomic_init(&t.next[1], 0);
#pragma omp parallel
    step_team_run(&t);
    const int cancelled = t.stop == 2;
    if (!cancelled && t.in != d->state)
        memcpy(d->state, t.in, bytes);
    free(other);
    free(partials);
    return cancelled ? vdbs_error_cancelled(err) : VDBS_OK;
}

/* ---- GPU path ---- */

/* A buffer of `size` bytes holding `data` (NULL: zeroed on the GPU, nothing uploaded). */
static vdbs_status upload(vdbs_runner *runner, size_t size, const void *data,
                          vdbs_gpu_buffer *buffer, vdbs_error *err)
{
    vdbs_status st = vdbs_gpu_buffer_create(runner->gpu, size, data, buffer, err);
    if (st == VDBS_OK && data)
        runner->transfer.uploaded += size;
    return st;
}

static vdbs_status read_back(vdbs_runner *runner, vdbs_gpu_buffer buffer, size_t size, void *dst,
                             vdbs_error *err)
{
    vdbs_status st = vdbs_gpu_buffer_read(runner->gpu, buffer, 0, size, dst, err);
    if (st == VDBS_OK)
        runner->transfer.read_back += size;
    return st;
}

typedef struct gpu_job {
    vdbs_runner *runner;
    vdbs_gpu *gpu;
    vdbs_gpu_program program;                       /* the runner's */
    vdbs_gpu_buffer inputs[VDBS_KERNEL_MAX_INPUTS]; /* 0 for resident ones (the runner's) */
    vdbs_gpu_buffer states[2];
    vdbs_gpu_buffer output;
    vdbs_gpu_buffer partials;
} gpu_job;

static void job_free(gpu_job *job)
{
    for (int i = 0; i < VDBS_KERNEL_MAX_INPUTS; ++i)
        vdbs_gpu_buffer_destroy(job->gpu, job->inputs[i]);
    vdbs_gpu_buffer_destroy(job->gpu, job->states[0]);
    if (job->states[1].id != job->states[0].id)
        vdbs_gpu_buffer_destroy(job->gpu, job->states[1]);
    vdbs_gpu_buffer_destroy(job->gpu, job->output);
    vdbs_gpu_buffer_destroy(job->gpu, job->partials);
}

/* The runner's program for `shader`, built on first use. */
static vdbs_status runner_program_get(vdbs_runner *runner, const char *shader,
                                      vdbs_gpu_program *program, vdbs_error *err)
{
    int slot = -1;
    for (int i = 0; i < RUNNER_MAX_PROGRAMS; ++i) {
        if (runner->programs[i].shader && strcmp(runner->programs[i].shader, shader) == 0) {
            *program = runner->programs[i].program;
            return VDBS_OK;
        }
        if (!runner->programs[i].shader && slot < 0)
            slot = i;
    }
    if (slot < 0)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "more than %d kernels in one runner",
                              RUNNER_MAX_PROGRAMS);
    const vdbs_shader_source *source = vdbs_shader_find(shader);
    if (!source)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "shader %s not embedded", shader);
    vdbs_status st = vdbs_gpu_program_create(runner->gpu, source, NULL, program, err);
    if (st == VDBS_OK)
        runner->programs[slot] = (runner_program){source->name, *program};
    return st;
}

/* A free slot of the resident table, grown when full; NULL when out of memory. */
static runner_resident *resident_free_slot(vdbs_runner *runner)
{
    for (int k = 0; k < runner->resident_slots; ++k)
        if (!runner->resident[k].id)
            return &runner->resident[k];
    int slots = runner->resident_slots ? 2 * runner->resident_slots : RUNNER_FIRST_RESIDENT;
    runner_resident *grown = realloc(runner->resident, sizeof *grown * (size_t)slots);
    if (!grown)
        return NULL;
    memset(grown + runner->resident_slots, 0,
           sizeof *grown * (size_t)(slots - runner->resident_slots));
    runner_resident *slot = grown + runner->resident_slots;
    runner->resident = grown;
    runner->resident_slots = slots;
    return slot;
}

/* The runner's buffer of a resident input, uploaded when its id is new or its size changed. */
static vdbs_status resident_buffer(vdbs_runner *runner, const vdbs_kernel_input *in,
                                   vdbs_gpu_buffer *buffer, vdbs_error *err)
{
    runner_resident *slot = NULL;
    for (int k = 0; k < runner->resident_slots && !slot; ++k)
        if (runner->resident[k].id == in->resident)
            slot = &runner->resident[k];
    if (slot && slot->size != in->size) {
        vdbs_runner_release(runner, in->resident);
        slot = NULL;
    }
    if (!slot) {
        if (!(slot = resident_free_slot(runner)))
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for resident inputs");
        vdbs_status st = upload(runner, in->size, in->data, &slot->buffer, err);
        if (st != VDBS_OK)
            return st;
        runner->transfer.resident_uploaded += in->size;
        slot->id = in->resident;
        slot->size = in->size;
    }
    *buffer = slot->buffer;
    return VDBS_OK;
}

/* Binds input i: a resident one from the runner's buffers, else a buffer of this job. */
static vdbs_status bind_input(gpu_job *job, const vdbs_kernel_input *in, int i, vdbs_error *err)
{
    vdbs_gpu_buffer buffer = {0};
    vdbs_status st = in->resident ? resident_buffer(job->runner, in, &buffer, err)
                                  : upload(job->runner, in->size, in->data, &job->inputs[i], err);
    if (st == VDBS_OK)
        vdbs_gpu_buffer_bind(job->gpu, in->resident ? buffer : job->inputs[i], (unsigned)i);
    return st;
}

/* Builds the program and uploads the inputs; the state buffers start with `state`
 * (may be NULL: zeroed). */
static vdbs_status job_init(gpu_job *job, vdbs_runner *runner, const vdbs_kernel_desc *d,
                            const void *state, vdbs_error *err)
{
    memset(job, 0, sizeof *job);
    job->runner = runner;
    job->gpu = runner->gpu;
    if (!d->shader)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "kernel without a shader");
    vdbs_status st = runner_program_get(runner, d->shader, &job->program, err);
    for (int i = 0; i < VDBS_KERNEL_MAX_INPUTS && st == VDBS_OK; ++i)
        if (d->inputs[i].size > 0)
            st = bind_input(job, &d->inputs[i], i, err);
    for (int i = 0; i < (d->in_place ? 1 : 2) && st == VDBS_OK; ++i)
        st = upload(runner, state_bytes(d), i == 0 ? state : NULL, &job->states[i], err);
    /* In place: both bindings name one buffer (the steps touch different items). */
    if (d->in_place)
        job->states[1] = job->states[0];
    if (st == VDBS_OK)
        st = upload(runner, d->output_words * 4u * (size_t)d->items, NULL, &job->output, err);
    uint64_t groups = (d->items + VS_PASS_LOCAL_SIZE - 1) / VS_PASS_LOCAL_SIZE;
    if (st == VDBS_OK)
        st = upload(runner, sizeof(float) * (size_t)groups, NULL, &job->partials, err);
    if (st == VDBS_OK) {
        vdbs_gpu_buffer_bind(job->gpu, job->output, VS_PASS_BINDING_OUTPUT);
        vdbs_gpu_buffer_bind(job->gpu, job->partials, VS_PASS_BINDING_REDUCE);
    } else {
        job_free(job);
    }
    return st;
}

/* One dispatch over all items from states[in] to states[1 - in]; control is updated with
 * what the shader reported. */
static vdbs_status job_dispatch(gpu_job *job, const vdbs_kernel_desc *d, int in,
                                uint32_t control[VS_PASS_WORDS], vdbs_error *err)
{
    vdbs_gpu_buffer control_buffer = {0};
    vdbs_status st =
        upload(job->runner, sizeof(uint32_t) * VS_PASS_WORDS, control, &control_buffer, err);
    if (st != VDBS_OK)
        return st;
    vdbs_gpu_buffer_bind(job->gpu, control_buffer, VS_PASS_BINDING_CONTROL);
    vdbs_gpu_buffer_bind(job->gpu, job->states[in], VS_PASS_BINDING_STATE_IN);
    vdbs_gpu_buffer_bind(job->gpu, job->states[1 - in], VS_PASS_BINDING_STATE_OUT);
    st = vdbs_gpu_dispatch_items(job->gpu, job->program, d->items, VS_PASS_LOCAL_SIZE, d->gpu_chunk,
                                 NULL, NULL, err);
    if (st == VDBS_OK)
        st = read_back(job->runner, control_buffer, sizeof(uint32_t) * VS_PASS_WORDS, control, err);
    vdbs_gpu_buffer_destroy(job->gpu, control_buffer);
    return st;
}

static void control_init(uint32_t control[VS_PASS_WORDS], int64_t units, int64_t done)
{
    memset(control, 0, sizeof(uint32_t) * VS_PASS_WORDS);
    control[VS_PASS_UNITS] = (uint32_t)(units < MAX_UNITS ? units : MAX_UNITS);
    control[VS_PASS_DONE] = (uint32_t)(done < MAX_UNITS ? done : MAX_UNITS);
    control[VS_PASS_CANARY_TRIPS] = CANARY_TRIPS;
    control[VS_PASS_CANARY_STEP] = 1u;
}

static vdbs_status gpu_run(vdbs_runner *runner, const vdbs_kernel_desc *d,
                           vdbs_kernel_result *result, vdbs_error *err)
{
    gpu_job job;
    vdbs_status st = job_init(&job, runner, d, NULL, err);
    if (st != VDBS_OK)
        return st;
    int64_t units = d->units_per_dispatch > 0 ? d->units_per_dispatch : MAX_UNITS;
    int64_t done = 0;
    int in = 0;
    while (st == VDBS_OK) {
        if (desc_cancelled(d)) {
            st = vdbs_error_cancelled(err);
            break;
        }
        uint32_t control[VS_PASS_WORDS];
        control_init(control, units, done);
        st = job_dispatch(&job, d, in, control, err);
        ++result->dispatches;
        if (st != VDBS_OK)
            break;
        if (control[VS_PASS_FAILED]) {
            /* The input states are untouched: the same pass again with fewer units. */
            if (units == 1) {
                st = vdbs_error_set(err, VDBS_ERR_GPU,
                                    "%s: a single unit of work exceeds the GPU driver's loop "
                                    "limit; use --backend cpu",
                                    d->shader);
                break;
            }
            units = units / 2;
            ++result->retries;
            continue;
        }
        done += units;
        in = 1 - in;
        uint64_t left = control[VS_PASS_LEFT];
        if (d->progress) {
            uint64_t finished = d->items - left;
            if (d->total_units > 0 && left > 0)
                finished = d->items * (uint64_t)(done < d->total_units ? done : d->total_units) /
                           (uint64_t)d->total_units;
            vdbs_progress_update(d->progress, finished);
        }
        if (left == 0)
            break;
        /* A kernel that keeps reporting work beyond its own unit count would loop forever. */
        if (d->total_units > 0 && done >= d->total_units) {
            st = vdbs_error_set(err, VDBS_ERR_INTERNAL,
                                "%s: %" PRIu64 " items unfinished after all %d units", d->shader,
                                left, d->total_units);
            break;
        }
    }
    if (st == VDBS_OK && d->output)
        st = read_back(runner, job.output, d->output_words * 4u * (size_t)d->items, d->output, err);
    job_free(&job);
    return st;
}

/* Step `it` of an iterate on the GPU: its dispatch, and its reduction read back and combined
 * (unless the caller wants none). */
static vdbs_status gpu_step(gpu_job *job, const vdbs_kernel_desc *d, int it, int in,
                            float *partials, size_t groups, double *reduction, vdbs_error *err)
{
    uint32_t control[VS_PASS_WORDS];
    control_init(control, 1, it);
    vdbs_status st = job_dispatch(job, d, in, control, err);
    if (st == VDBS_OK && control[VS_PASS_FAILED])
        st = vdbs_error_set(err, VDBS_ERR_GPU,
                            "%s: one step exceeds the GPU driver's loop limit; use "
                            "--backend cpu",
                            d->shader);
    *reduction = 0.0;
    if (st != VDBS_OK || d->reduce == VDBS_REDUCE_NONE)
        return st;
    st = read_back(job->runner, job->partials, sizeof(float) * groups, partials, err);
    for (size_t g = 0; g < groups && st == VDBS_OK; ++g)
        *reduction = combine(d->reduce, *reduction, (double)partials[g]);
    return st;
}

static vdbs_status gpu_iterate(vdbs_runner *runner, const vdbs_kernel_desc *d, int max_iterations,
                               vdbs_kernel_result *result, vdbs_error *err)
{
    const size_t groups = (size_t)((d->items + VS_PASS_LOCAL_SIZE - 1) / VS_PASS_LOCAL_SIZE);
    float *partials = malloc(sizeof *partials * (groups ? groups : 1));
    if (!partials)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu partial sums", groups);
    gpu_job job;
    vdbs_status st = job_init(&job, runner, d, d->state_zeroed ? NULL : d->state, err);
    if (st != VDBS_OK) {
        free(partials);
        return st;
    }
    int in = 0;
    for (int it = 0; it < max_iterations && st == VDBS_OK; ++it) {
        if (desc_cancelled(d)) {
            st = vdbs_error_cancelled(err);
            break;
        }
        double reduction = 0.0;
        st = gpu_step(&job, d, it, in, partials, groups, &reduction, err);
        ++result->dispatches;
        if (st != VDBS_OK)
            break;
        in = 1 - in;
        if (step_done(d, it, reduction, result))
            break;
    }
    if (st == VDBS_OK)
        st = read_back(runner, job.states[in], state_bytes(d), d->state, err);
    job_free(&job);
    free(partials);
    return st;
}

/* ---- entry points ---- */

/* Zeroes the result (a local one when the caller passed none); 0: no items, nothing to do. */
static int kernel_start(const vdbs_kernel_desc *desc, vdbs_kernel_result **result,
                        vdbs_kernel_result *local)
{
    *result = *result ? *result : local;
    memset(*result, 0, sizeof **result);
    return desc->items > 0;
}

static vdbs_status no_c_path(const vdbs_kernel_desc *desc, vdbs_error *err)
{
    return vdbs_error_set(err, VDBS_ERR_INTERNAL, "kernel %s has no C path",
                          desc->shader ? desc->shader : "(unnamed)");
}

vdbs_status vdbs_kernel_run(vdbs_runner *runner, const vdbs_kernel_desc *desc,
                            vdbs_kernel_result *result, vdbs_error *err)
{
    vdbs_kernel_result local;
    if (!kernel_start(desc, &result, &local))
        return VDBS_OK;
    if (runner->backend == VDBS_BACKEND_GPU)
        return gpu_run(runner, desc, result, err);
    if (!desc->cpu_items)
        return no_c_path(desc, err);
    return cpu_run(desc) ? vdbs_error_cancelled(err) : VDBS_OK;
}

vdbs_status vdbs_kernel_iterate(vdbs_runner *runner, const vdbs_kernel_desc *desc,
                                vdbs_kernel_result *result, vdbs_error *err)
{
    vdbs_kernel_result local;
    if (!kernel_start(desc, &result, &local))
        return VDBS_OK;
    if (!desc->state)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "iterate: no state");
    int max_iterations = desc->max_iterations > 0 ? desc->max_iterations : 1;
    if (runner->backend == VDBS_BACKEND_GPU)
        return gpu_iterate(runner, desc, max_iterations, result, err);
    if (!desc->cpu_step)
        return no_c_path(desc, err);
    return cpu_iterate(desc, max_iterations, result, err);
}
