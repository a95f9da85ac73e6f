#include "vdbscatter/render.h"

#include "vdbscatter/advice.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/fog.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/medium.h"
#include "vdbscatter/reference.h"
#include "vdbscatter/quality.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/scene_file.h"

#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_lightgrid.h"
#include "vs_envmap.h"
#include "vs_shadow.h"
#include "vs_march.h"
#include "vs_phase.h"
#include "vs_render.h"
#include "vs_gather.h"
#include "vs_fog.h"
#include "vs_fogpass.h"

/* Pixels per GPU dispatch chunk: short enough for a display driver's watchdog on real
 * GPUs, large enough to keep llvmpipe's threads busy. */
#define RENDER_GPU_CHUNK 4096u
/* Pixels per C task: rays differ a lot in cost. */
#define RENDER_CPU_CHUNK 16u

int vdbs_render_quality(const char *quality, vdbs_march_options *options)
{
    const vdbs_quality *q = vdbs_quality_find(quality);
    if (!q)
        return 0;
    options->sky_directions = q->sky_directions;
    options->step_voxels = q->render_step_voxels;
    options->s1_oversample = q->s1_oversample;
    return 1;
}

/* Byte offsets of the four ms grids in the render buffer (density first). */
static void ms_offsets(const vdbs_volume *volume, const vdbs_ms_grids *ms, uint64_t offsets[4])
{
    uint64_t at = volume->nano_size;
    const size_t sizes[4] = {ms->ms_size, ms->l1x_size, ms->l1y_size, ms->l1z_size};
    for (int i = 0; i < 4; ++i) {
        at = (at + 31u) / 32u * 32u;
        offsets[i] = at;
        at += sizes[i];
    }
}

/* A pinhole camera's rows of a kernel table (vs_pinhole_direction): (forward, height),
 * (right * tan(half fov x), 0), (up * tan(half fov y), 0). */
static void put_pinhole(float *forward, float *right, float *up, const vdbs_camera_frame *frame)
{
    vdbs_table_put(forward, frame->forward[0], frame->forward[1], frame->forward[2], frame->height);
    vdbs_table_put(right, frame->right[0] * frame->tan_half_x, frame->right[1] * frame->tan_half_x,
                   frame->right[2] * frame->tan_half_x, 0.0);
    vdbs_table_put(up, frame->up[0] * frame->tan_half_y, frame->up[1] * frame->tan_half_y,
                   frame->up[2] * frame->tan_half_y, 0.0);
}

vdbs_status vdbs_render_table(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              float **data, size_t *entries, vdbs_error *err)
{
    *data = NULL;
    *entries = 0;
    if (!(options->step_voxels > 0.0f) || !isfinite(options->step_voxels) ||
        options->sky_directions < 1)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "render: bad march options (step %g voxels, %d sky directions)",
                              (double)options->step_voxels, options->sky_directions);
    float *t = calloc(VS_RENDER_SIZE, 4 * sizeof *t);
    if (!t)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the render table");
    int with_ms = vdbs_ms_grids_present(ms);
    vdbs_table_put(t + 4 * VS_RENDER_OFF_MARCH, options->step_voxels, with_ms ? 1.0 : 0.0, 0.0,
                   0.0);
    if (with_ms) {
        uint64_t offsets[4];
        ms_offsets(volume, ms, offsets);
        uint64_t units[4];
        for (int i = 0; i < 4; ++i) {
            units[i] = offsets[i] / 32u;
            if (units[i] >> 40) {
                free(t);
                return vdbs_error_set(err, VDBS_ERR_INPUT, "lit grids too large to address");
            }
        }
        vdbs_table_put(t + 4 * VS_RENDER_OFF_GRIDS, (double)(units[0] >> 16),
                       (double)(units[0] & 0xffffu), (double)(units[1] >> 16),
                       (double)(units[1] & 0xffffu));
        vdbs_table_put(t + 4 * VS_RENDER_OFF_GRIDS_L1YZ, (double)(units[2] >> 16),
                       (double)(units[2] & 0xffffu), (double)(units[3] >> 16),
                       (double)(units[3] & 0xffffu));
    }
    vdbs_table_put(t + 4 * VS_RENDER_OFF_VIEW, options->interleave > 1 ? options->interleave : 1,
                   options->no_single ? 0.0 : 1.0, 0.0, 0.0);
    vdbs_table_put(t + 4 * VS_RENDER_OFF_WORLD_ORIGIN, frame->origin[0], frame->origin[1],
                   frame->origin[2], 0.0);
    double origin[3];
    vdbs_volume_index_point(volume, frame->origin, origin);
    vdbs_table_put(t + 4 * VS_RENDER_OFF_ORIGIN, origin[0], origin[1], origin[2], frame->width);
    put_pinhole(t + 4 * VS_RENDER_OFF_FORWARD, t + 4 * VS_RENDER_OFF_RIGHT,
                t + 4 * VS_RENDER_OFF_UP, frame);
    *data = t;
    *entries = VS_RENDER_SIZE;
    return VDBS_OK;
}

vdbs_status vdbs_render_buffer(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                               uint32_t **buffer, size_t *size, int *owned, vdbs_error *err)
{
    if (!vdbs_ms_grids_present(ms)) {
        *buffer = volume->nano;
        *size = volume->nano_size;
        *owned = 0;
        return VDBS_OK;
    }
    uint64_t offsets[4];
    ms_offsets(volume, ms, offsets);
    size_t total = (size_t)offsets[3] + ms->l1z_size;
    uint32_t *b = aligned_alloc(32, (total + 31u) / 32u * 32u);
    if (!b)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu bytes of grids", total);
    memset(b, 0, (total + 31u) / 32u * 32u);
    memcpy(b, volume->nano, volume->nano_size);
    const uint32_t *src[4] = {ms->ms, ms->l1x, ms->l1y, ms->l1z};
    const size_t sizes[4] = {ms->ms_size, ms->l1x_size, ms->l1y_size, ms->l1z_size};
    for (int i = 0; i < 4; ++i)
        memcpy((char *)b + offsets[i], src[i], sizes[i]);
    *buffer = b;
    *size = total;
    *owned = 1;
    return VDBS_OK;
}

static vdbs_status check_image(const vdbs_camera_frame *frame, const vdbs_image *image,
                               vdbs_error *err)
{
    if (!image->rgb || image->width != frame->width || image->height != frame->height ||
        frame->width < 1 || frame->height < 1)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "render: image of %dx%d for a camera of %dx%d", image->width,
                              image->height, frame->width, frame->height);
    return VDBS_OK;
}

typedef struct march_job {
    const vs_vec4 *medium_data;
    const vs_vec4 *light_data;
    const vs_vec4 *render_data;
    const vs_uint *lgrid_data;
    const float *env_data;
    const float *shadow_data;
    const vs_vec4 *backdrop_data;
    pnanovdb_buf_t buf;
    int width;
    float *rgb;
} march_job;

static void march_items(void *user, uint64_t begin, uint64_t end)
{
    const march_job *job = user;
    vs_render_accessors accs = vs_render_accessors_init(job->render_data, job->buf);
    for (uint64_t n = begin; n < end; ++n) {
        pnanovdb_vec3_t L =
            vs_render_pixel(job->medium_data, job->light_data, job->render_data, job->lgrid_data,
                            job->env_data, job->shadow_data, job->backdrop_data, job->buf, &accs,
                            (int)(n % (uint64_t)job->width), (int)(n / (uint64_t)job->width));
        job->rgb[3 * n] = L.x;
        job->rgb[3 * n + 1] = L.y;
        job->rgb[3 * n + 2] = L.z;
    }
}

/* What a session keeps between pictures: everything but the camera. On the GPU the
 * grids, lights and light grids stay resident under the runner's ids. */
struct vdbs_march_session {
    vdbs_runner *runner;
    const vdbs_volume *volume;
    const vdbs_ms_grids *ms;
    vdbs_march_options options; /* as given to create (the lights' settings) */
    uint32_t *grids;            /* density then ms grids (vdbs_render_buffer) */
    size_t grids_size;
    int grids_owned;
    int have_lights;
    vdbs_light_table lights;
    vdbs_light_grids light_grids;
    float medium[4 * VDBS_MEDIUM_TABLE_ENTRIES];
    float no_env[VS_ENV_OFF_TEXELS];
    uint32_t no_grids[4];
    float no_shadows[VS_SHADOW_OFF_ENTRIES]; /* count 0 */
    float no_backdrop[4];                    /* one far "surface", for a frame without one */
    const float *shadows;                    /* the caller's (vs_shadow.h) or no_shadows */
    size_t shadow_floats;
    uint64_t id_grids, id_lights, id_light_grids, id_env, id_shadows;
};

void vdbs_march_session_tables(const vdbs_march_session *s, vdbs_march_tables *out)
{
    out->lights = s->lights.packed;
    out->light_floats = s->lights.packed_entries * 4;
    out->medium = s->medium;
    out->medium_floats = sizeof s->medium / sizeof s->medium[0];
    out->light_grids = s->options.s1_march ? NULL : s->light_grids.words;
    out->light_grid_words = s->options.s1_march ? 0 : s->light_grids.word_count;
}

void vdbs_march_session_set_shadows(vdbs_march_session *s, const float *table, size_t floats)
{
    vdbs_runner_release(s->runner, s->id_shadows);
    s->shadows = table && floats >= VS_SHADOW_OFF_ENTRIES ? table : s->no_shadows;
    s->shadow_floats = table && floats >= VS_SHADOW_OFF_ENTRIES ? floats : VS_SHADOW_OFF_ENTRIES;
    s->id_shadows = vdbs_runner_resident_id(s->runner);
}

static void session_drop_lights(vdbs_march_session *s)
{
    if (!s->have_lights)
        return;
    vdbs_runner_release(s->runner, s->id_lights);
    vdbs_runner_release(s->runner, s->id_light_grids);
    vdbs_runner_release(s->runner, s->id_env);
    vdbs_light_grids_free(&s->light_grids);
    vdbs_lights_free(&s->lights);
    s->have_lights = 0;
}

void vdbs_march_session_destroy(vdbs_march_session *session)
{
    if (!session)
        return;
    session_drop_lights(session);
    vdbs_runner_release(session->runner, session->id_grids);
    vdbs_runner_release(session->runner, session->id_shadows);
    if (session->grids_owned)
        free(session->grids);
    free(session);
}

vdbs_status vdbs_march_session_create(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_ms_grids *ms, const vdbs_scene *scene,
                                      const vdbs_march_options *options, vdbs_march_session **out,
                                      vdbs_error *err)
{
    *out = NULL;
    vdbs_march_session *s = calloc(1, sizeof *s);
    if (!s)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a render session");
    s->runner = runner;
    s->volume = volume;
    s->no_backdrop[0] = VS_T_INFINITE;
    s->ms = vdbs_ms_grids_present(ms) ? ms : NULL;
    s->options = *options;
    vdbs_status st =
        vdbs_render_buffer(volume, s->ms, &s->grids, &s->grids_size, &s->grids_owned, err);
    /* GLSL addresses bytes with 32-bit unsigned integers. */
    if (st == VDBS_OK && vdbs_runner_backend(runner) == VDBS_BACKEND_GPU &&
        s->grids_size > 0xffffffffu)
        st = vdbs_error_set(err, VDBS_ERR_GPU,
                            "%zu bytes of grids exceed the 4 GiB a shader can address; use "
                            "--backend cpu",
                            s->grids_size);
    s->id_grids = vdbs_runner_resident_id(runner);
    vdbs_march_session_set_shadows(s, NULL, 0);
    if (st == VDBS_OK)
        st = vdbs_march_session_set_scene(s, scene, err);
    if (st != VDBS_OK) {
        vdbs_march_session_destroy(s);
        return st;
    }
    *out = s;
    return VDBS_OK;
}

vdbs_status vdbs_march_session_set_scene(vdbs_march_session *s, const vdbs_scene *scene,
                                         vdbs_error *err)
{
    session_drop_lights(s);
    const vdbs_march_options *options = &s->options;
    vdbs_lights_desc lights_desc = {0};
    lights_desc.sky_ordinates = options->sky_directions;
    vdbs_status st = vdbs_lights_build(s->volume, scene, &lights_desc, &s->lights, err);
    if (st != VDBS_OK)
        return st;
    memset(&s->light_grids, 0, sizeof s->light_grids);
    s->have_lights = 1;
    s->id_lights = vdbs_runner_resident_id(s->runner);
    s->id_light_grids = vdbs_runner_resident_id(s->runner);
    s->id_env = vdbs_runner_resident_id(s->runner);
    /* The light grids of every light and sky ordinate, built once (none for the march).
     * Bilinear across columns: a camera sample's error averages along the ray and over the
     * lights, and the lookups are memory-bound (bench/RESULTS.md). */
    if (!options->s1_march) {
        vdbs_light_grid_desc gd = {options->s1_oversample, 1};
        st = vdbs_light_grids_build(s->runner, s->volume, scene, &s->lights, 0,
                                    s->lights.direct_count + s->lights.ordinate_count, &gd,
                                    &s->light_grids, err);
        if (st == VDBS_OK)
            st = vdbs_light_grids_fit(s->runner, &s->light_grids, err);
        if (options->stats)
            options->stats->grids = s->light_grids.stats;
    }
    vdbs_medium medium_params;
    vdbs_medium_init(&medium_params, s->volume, scene);
    vdbs_medium_pack(&medium_params, s->medium);
    return st;
}

/* Interleaved sampling's gather (vs_gather.h): across, then down. */
typedef struct gather_job {
    const vs_vec4 *table;
    const float *in;
    float *out;
} gather_job;

static void gather_items(void *user, uint64_t begin, uint64_t end)
{
    const gather_job *job = user;
    for (uint64_t n = begin; n < end; ++n)
        for (int c = 0; c < 3; ++c)
            job->out[3 * n + (uint64_t)c] = vs_gather_channel(job->table, job->in, (int)n, c);
}

vdbs_status vdbs_render_gather(vdbs_runner *runner, vdbs_image *image, int block, vdbs_error *err)
{
    if (block <= 1)
        return VDBS_OK;
    size_t pixels = (size_t)image->width * (size_t)image->height;
    float *other = malloc(sizeof *other * 3 * (pixels ? pixels : 1));
    if (!other)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the gather pass");
    vdbs_status st = VDBS_OK;
    float *in = image->rgb, *out = other;
    for (int down = 0; down < 2 && st == VDBS_OK; ++down) {
        float table[4 * VS_GATHER_SIZE] = {(float)image->width, (float)image->height, (float)block,
                                           (float)down};
        gather_job job = {(const vs_vec4 *)table, in, out};
        vdbs_kernel_desc desc = {0};
        desc.items = pixels;
        desc.user = &job;
        desc.cpu_items = gather_items;
        desc.cpu_chunk = 1024;
        desc.shader = "render_gather.comp";
        desc.inputs[1] = (vdbs_kernel_input){.data = table, .size = sizeof table};
        desc.inputs[2] = (vdbs_kernel_input){.data = in, .size = sizeof *in * 3 * pixels};
        desc.output_words = 3;
        desc.output = out;
        st = vdbs_kernel_run(runner, &desc, NULL, err);
        float *t = in;
        in = out;
        out = t;
    }
    /* Two passes: the result is back in image->rgb. */
    free(other);
    return st;
}

/* The fog pass (vs_fogpass.h) over image->rgb. */
typedef struct fog_job {
    const vs_vec4 *pass;
    const vs_vec4 *lights;
    const float *fog;
    const float *shadows;
    const vs_vec4 *backdrop;
    const float *in;
    float *out;
    int width;
} fog_job;

static void fog_items(void *user, uint64_t begin, uint64_t end)
{
    const fog_job *job = user;
    for (uint64_t n = begin; n < end; ++n) {
        pnanovdb_vec3_t behind = vs_vec3(job->in[3 * n], job->in[3 * n + 1], job->in[3 * n + 2]);
        pnanovdb_vec3_t L = vs_fogpass_pixel(job->pass, job->lights, job->fog, job->shadows,
                                             job->backdrop, (int)(n % (uint64_t)job->width),
                                             (int)(n / (uint64_t)job->width), behind);
        job->out[3 * n] = L.x;
        job->out[3 * n + 1] = L.y;
        job->out[3 * n + 2] = L.z;
    }
}

static vdbs_status fog_pass(vdbs_march_session *s, const vdbs_camera_frame *frame,
                            const vdbs_march_options *options, int block, vdbs_image *image,
                            vdbs_error *err)
{
    const vdbs_march_fog *f = options->fog;
    float pass[4 * VS_FOGPASS_SIZE];
    vdbs_table_put(pass + 4 * VS_FOGPASS_OFF_ORIGIN, frame->origin[0], frame->origin[1],
                   frame->origin[2], frame->width);
    put_pinhole(pass + 4 * VS_FOGPASS_OFF_FORWARD, pass + 4 * VS_FOGPASS_OFF_RIGHT,
                pass + 4 * VS_FOGPASS_OFF_UP, frame);
    vdbs_table_put(pass + 4 * VS_FOGPASS_OFF_BOX_LO, f->box_lo[0], f->box_lo[1], f->box_lo[2],
                   f->steps > 0 ? f->steps : 64);
    vdbs_table_put(pass + 4 * VS_FOGPASS_OFF_BOX_HI, f->box_hi[0], f->box_hi[1], f->box_hi[2],
                   block);
    vdbs_table_put(pass + 4 * VS_FOGPASS_OFF_ALBEDO, f->albedo[0], f->albedo[1], f->albedo[2],
                   options->backdrop ? 1.0 : 0.0);
    size_t pixels = (size_t)frame->width * (size_t)frame->height;
    float *out = malloc(sizeof *out * 3 * (pixels ? pixels : 1));
    if (!out)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the fog pass");
    const float *backdrop = options->backdrop ? options->backdrop : s->no_backdrop;
    fog_job job = {(const vs_vec4 *)pass,
                   (const vs_vec4 *)s->lights.packed,
                   f->fog->table,
                   s->shadows,
                   (const vs_vec4 *)backdrop,
                   image->rgb,
                   out,
                   frame->width};
    vdbs_kernel_desc desc = {0};
    desc.items = pixels;
    desc.user = &job;
    desc.cpu_items = fog_items;
    desc.cpu_chunk = 64;
    desc.shader = "fog_composite.comp";
    desc.inputs[1] = (vdbs_kernel_input){.data = pass, .size = sizeof pass};
    desc.inputs[2] = (vdbs_kernel_input){
        s->lights.packed, s->lights.packed_entries * 4 * sizeof(float), s->id_lights};
    desc.inputs[3] =
        (vdbs_kernel_input){.data = f->fog->table, .size = sizeof(float) * f->fog->table_floats};
    desc.inputs[4] =
        (vdbs_kernel_input){s->shadows, sizeof(float) * s->shadow_floats, s->id_shadows};
    desc.inputs[5] = (vdbs_kernel_input){.data = backdrop,
                                         .size = options->backdrop ? 4 * sizeof(float) * pixels
                                                                   : sizeof s->no_backdrop};
    desc.inputs[6] = (vdbs_kernel_input){.data = image->rgb, .size = sizeof(float) * 3 * pixels};
    desc.output_words = 3;
    desc.output = out;
    vdbs_status st = vdbs_kernel_run(s->runner, &desc, NULL, err);
    if (st == VDBS_OK)
        memcpy(image->rgb, out, sizeof *out * 3 * pixels);
    free(out);
    return st;
}

vdbs_status vdbs_march_session_draw(vdbs_march_session *s, const vdbs_camera_frame *frame,
                                    const vdbs_march_options *options, vdbs_image *image,
                                    vdbs_error *err)
{
    vdbs_status st = check_image(frame, image, err);
    if (st != VDBS_OK)
        return st;
    const int block = options->interleave > 1 ? options->interleave : 1;
    if (block > VDBS_MAX_INTERLEAVE)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "interleave block %d beyond %d", block,
                              VDBS_MAX_INTERLEAVE);
    float *table = NULL;
    size_t entries = 0;
    const vdbs_ms_grids *ms = options->no_multiple ? NULL : s->ms;
    if ((st = vdbs_render_table(s->volume, ms, frame, options, &table, &entries, err)) != VDBS_OK)
        return st;
    if (!s->options.s1_march)
        table[4 * VS_RENDER_OFF_MARCH + 2] = 1.0f;
    table[4 * VS_RENDER_OFF_WORLD_ORIGIN + 3] = options->backdrop ? 1.0f : 0.0f;
    const float *backdrop = options->backdrop ? options->backdrop : s->no_backdrop;
    const uint32_t *lgrid_words = s->options.s1_march ? s->no_grids : s->light_grids.words;
    size_t lgrid_bytes = s->options.s1_march
                             ? sizeof s->no_grids
                             : sizeof *s->light_grids.words * s->light_grids.word_count;
    /* The map the rays that leave see, already in the kernels' layout; a zero header
     * without one. */
    const float *env = s->lights.env ? s->lights.env->data : s->no_env;
    size_t env_bytes = s->lights.env ? s->lights.env->bytes : sizeof s->no_env;
    march_job job = {(const vs_vec4 *)s->medium,
                     (const vs_vec4 *)s->lights.packed,
                     (const vs_vec4 *)table,
                     lgrid_words,
                     env,
                     s->shadows,
                     (const vs_vec4 *)backdrop,
                     pnanovdb_make_buf(s->grids, s->grids_size / 4),
                     frame->width,
                     image->rgb};

    vdbs_kernel_desc desc = {0};
    desc.items = (uint64_t)frame->width * (uint64_t)frame->height;
    desc.user = &job;
    desc.cpu_items = march_items;
    desc.cpu_chunk = RENDER_CPU_CHUNK;
    desc.shader = "render_march.comp";
    desc.inputs[0] = (vdbs_kernel_input){s->grids, s->grids_size, s->id_grids};
    desc.inputs[1] = (vdbs_kernel_input){.data = s->medium, .size = sizeof s->medium};
    desc.inputs[2] = (vdbs_kernel_input){
        s->lights.packed, s->lights.packed_entries * 4 * sizeof(float), s->id_lights};
    desc.inputs[3] = (vdbs_kernel_input){.data = table, .size = entries * 4 * sizeof(float)};
    desc.inputs[4] = (vdbs_kernel_input){lgrid_words, lgrid_bytes, s->id_light_grids};
    desc.inputs[5] = (vdbs_kernel_input){env, env_bytes, s->id_env};
    desc.inputs[6] =
        (vdbs_kernel_input){s->shadows, sizeof(float) * s->shadow_floats, s->id_shadows};
    desc.inputs[7] = (vdbs_kernel_input){
        .data = backdrop,
        .size = options->backdrop ? 4 * sizeof(float) * (size_t)desc.items : sizeof s->no_backdrop};
    desc.state_words = VS_RENDER_STATE_WORDS;
    desc.output_words = 3;
    desc.output = image->rgb;
    desc.units_per_dispatch =
        options->gpu_units > 0 ? options->gpu_units : vdbs_volume_gpu_marches_per_pass(s->volume);
    desc.gpu_chunk = RENDER_GPU_CHUNK;
    desc.progress = options->progress;
    double t_march = omp_get_wtime();
    st = vdbs_kernel_run(s->runner, &desc, NULL, err);
    if (st == VDBS_OK && options->fog && options->fog->fog)
        st = fog_pass(s, frame, options, block, image, err);
    if (st == VDBS_OK)
        st = vdbs_render_gather(s->runner, image, block, err);
    if (options->stats)
        options->stats->seconds_march = omp_get_wtime() - t_march;
    free(table);
    return st;
}

vdbs_status vdbs_render_march(vdbs_runner *runner, const vdbs_volume *volume,
                              const vdbs_ms_grids *ms, const vdbs_scene *scene,
                              const vdbs_camera_frame *frame, const vdbs_march_options *options,
                              vdbs_image *image, vdbs_error *err)
{
    vdbs_march_session *session = NULL;
    vdbs_status st;
    if ((st = vdbs_march_session_create(runner, volume, ms, scene, options, &session, err)) !=
        VDBS_OK)
        return st;
    /* Between the light grids and the camera rays (which poll it themselves). */
    st = vdbs_progress_cancelled(options->progress)
             ? vdbs_error_cancelled(err)
             : vdbs_march_session_draw(session, frame, options, image, err);
    vdbs_march_session_destroy(session);
    return st;
}

/* ---- the render job ---- */

static const char *const mode_names[] = {NULL, "single", "baked", "reference"};

const char *vdbs_render_mode_name(vdbs_render_mode mode)
{
    return mode >= VDBS_RENDER_SINGLE && mode <= VDBS_RENDER_REFERENCE ? mode_names[mode] : NULL;
}

static void warn(const vdbs_render_desc *d, const char *message)
{
    if (d->warn)
        d->warn(d->warn_user, message);
}

/* The scene of a lit VDB: its baked scene with the caller's explicit settings on top. */
static void apply_overrides(unsigned set, const vdbs_scene *given, vdbs_scene *scene)
{
    if (set & VDBS_SCENE_SET_DENSITY_SCALE) {
        scene->density_scale = given->density_scale;
        scene->density_target_depth = given->density_target_depth;
    }
    if (set & VDBS_SCENE_SET_ALBEDO)
        memcpy(scene->albedo, given->albedo, sizeof scene->albedo);
    if (set & VDBS_SCENE_SET_G)
        scene->g = given->g;
    if (set & VDBS_SCENE_SET_QUALITY) {
        memcpy(scene->quality, given->quality, sizeof scene->quality);
        scene->sky_directions = given->sky_directions; /* the quality's K unless also given */
    }
    if (set & VDBS_SCENE_SET_SKY_DIRECTIONS)
        scene->sky_directions = given->sky_directions;
    if (set & VDBS_SCENE_SET_LIGHTS)
        vdbs_scene_copy_lights(scene, given);
    if (set & VDBS_SCENE_SET_GRID) {
        memcpy(scene->grid, given->grid, sizeof scene->grid);
        scene->grid_index = given->grid_index;
    }
}

/* Opens the input: a lit VDB brings its baked scene (*is_lit), and the render scene is
 * resolved from it and the caller's. On success *lit is open (the caller closes it). */
static vdbs_status resolve_scene(const vdbs_render_desc *d, const char *input, vdbio_lit **lit,
                                 vdbs_render_mode *mode, int *is_lit, vdbs_scene *scene,
                                 char baked_method[32], vdbs_error *err)
{
    vdbs_status st = vdbio_lit_open(input, lit, err);
    if (st != VDBS_OK)
        return st;
    const char *meta = vdbio_lit_meta(*lit, "vdbscatter_scene");
    *is_lit = meta && vdbio_lit_has_grid(*lit, "radiance") && vdbio_lit_has_grid(*lit, "density");
    vdbs_scene *baked = malloc(sizeof *baked);
    if (!baked)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    if (*is_lit && (st = vdbs_scene_parse(meta, NULL, baked, err)) != VDBS_OK) {
        vdbs_error inner = *err;
        free(baked);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: vdbscatter_scene metadata: %s", input,
                              inner.message);
    }
    *mode = d->mode != VDBS_RENDER_DEFAULT ? d->mode
            : *is_lit                      ? VDBS_RENDER_BAKED
                                           : VDBS_RENDER_SINGLE;
    if (*mode == VDBS_RENDER_BAKED && !*is_lit) {
        free(baked);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--mode baked needs a lit VDB written by vdbscatter bake ('%s' has "
                              "no radiance grid and vdbscatter_scene metadata)",
                              input);
    }
    if (*is_lit)
        snprintf(baked_method, 32, "%s", baked->method);
    /* A scene file replaces the baked scene; flags alone go on top of it. */
    if (*is_lit && !(d->scene_set & VDBS_SCENE_FROM_FILE)) {
        *scene = *baked;
        apply_overrides(d->scene_set, d->scene, scene);
    } else {
        *scene = *d->scene;
        if (*is_lit && scene->light_count == 0)
            vdbs_scene_copy_lights(scene, baked);
    }
    free(baked);
    /* No light is reported after the density grid is found (vdbs_render_open). */
    return vdbs_scene_validate_opt(scene, 1, err);
}

/* Camera: the caller's, else the scene's, else a view of the whole volume. */
static void choose_camera(const vdbs_render_desc *d, const vdbs_scene *scene,
                          const vdbs_volume *volume, vdbs_camera *camera)
{
    int width = d->width > 0 ? d->width : 640, height = d->height > 0 ? d->height : 480;
    if (d->camera && d->camera->present) {
        *camera = *d->camera;
    } else if (scene->camera.present) {
        *camera = scene->camera;
        if (!(d->width > 0)) {
            width = camera->width;
            height = camera->height;
        }
    } else {
        vdbs_camera_frame_volume(volume, width, height, camera);
    }
    camera->width = width;
    camera->height = height;
}

static vdbs_status render_image(const vdbs_render_desc *d, vdbs_render_mode mode,
                                const vdbs_volume *volume, const vdbs_ms_grids *ms,
                                const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                vdbs_march_options *march, vdbs_image *image,
                                vdbs_render_report *report, vdbs_error *err)
{
    vdbs_progress progress = {0};
    progress.cancel = d->cancel;
    uint64_t pixels = (uint64_t)frame->width * (uint64_t)frame->height;
    vdbs_status st;
    if (mode == VDBS_RENDER_REFERENCE) {
        vdbs_reference_options ro = {0};
        ro.spp = d->spp > 0 ? d->spp : d->time_limit > 0.0 ? 4 : 64;
        ro.time_limit = d->time_limit;
        ro.max_bounces = d->max_bounces > 0 ? d->max_bounces : 1000;
        ro.seed = d->seed;
        ro.no_env_nee = d->no_env_nee;
        ro.progress = &progress;
        snprintf(report->backend, sizeof report->backend, "cpu");
        snprintf(report->renderer, sizeof report->renderer, "C (OpenMP, %d threads)",
                 omp_get_max_threads());
        vdbs_progress_begin(&progress, d->progress, "render (reference)",
                            pixels * (uint64_t)ro.spp);
        st = vdbs_reference_render(volume, scene, frame, &ro, image, &report->spp, err);
    } else {
        vdbs_runner_desc rd = {.backend = d->backend};
        vdbs_runner *runner = NULL;
        if ((st = vdbs_runner_create(&rd, &runner, err)) != VDBS_OK)
            return st;
        snprintf(report->backend, sizeof report->backend, "%s", vdbs_runner_backend_name(runner));
        snprintf(report->renderer, sizeof report->renderer, "%s", vdbs_runner_device(runner));
        march->progress = &progress;
        march->gpu_units = d->gpu_units;
        march->s1_march = d->s1_march;
        if (d->s1_oversample > 0)
            march->s1_oversample = d->s1_oversample;
        march->stats = &report->march_stats;
        snprintf(report->s1, sizeof report->s1, "%s", d->s1_march ? "march" : "grid");
        report->s1_oversample = d->s1_march                ? 0
                                : march->s1_oversample > 0 ? march->s1_oversample
                                                           : VDBS_LIGHT_GRID_DEFAULT_OVERSAMPLE;
        report->spp = 1;
        vdbs_progress_begin(&progress, d->progress, "render", pixels);
        st = vdbs_render_march(runner, volume, mode == VDBS_RENDER_BAKED ? ms : NULL, scene, frame,
                               march, image, err);
        vdbs_runner_destroy(runner);
    }
    if (st == VDBS_OK)
        vdbs_progress_end(&progress);
    return st;
}

/* The VDB a render reads: the desc's, else its scene's volume file. */
static vdbs_status input_path(const vdbs_render_desc *d, const char **input, vdbs_error *err)
{
    *input = d->input ? d->input : d->scene->volume_file;
    if (!*input || !(*input)[0])
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "no input VDB (give IN.vdb or volume.file in --scene)");
    return VDBS_OK;
}

vdbs_status vdbs_render_open(const vdbs_render_desc *d, vdbs_render_input *in, vdbs_error *err)
{
    memset(in, 0, sizeof *in);
    const char *input = NULL;
    vdbs_status st = input_path(d, &input, err);
    if (st != VDBS_OK)
        return st;
    in->scene = malloc(sizeof *in->scene);
    if (!in->scene)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    vdbio_lit *lit = NULL;
    st = resolve_scene(d, input, &lit, &in->mode, &in->is_lit, in->scene, in->baked_method, err);
    if (st == VDBS_OK) {
        for (int i = 0; i < in->scene->light_count; ++i)
            if (in->scene->lights[i].type == VDBS_LIGHT_SUN &&
                in->scene->lights[i].angular_diameter_deg > 0) {
                warn(d, "sun angular_diameter_deg is treated as 0 (a delta light)");
                break;
            }
        if (in->mode == VDBS_RENDER_REFERENCE && d->backend == VDBS_BACKEND_GPU)
            warn(d, "--mode reference runs on the C path; --backend gpu is ignored");
        if (!vdbs_render_quality(in->scene->quality, &in->march))
            st = vdbs_error_set(err, VDBS_ERR_INPUT, "unknown quality");
        if (in->scene->sky_directions > 0)
            in->march.sky_directions = in->scene->sky_directions;
    }
    /* The density: a lit VDB's own `density` grid unless the caller names one. */
    if (st == VDBS_OK) {
        int own_grid = in->is_lit && !(d->scene_set & VDBS_SCENE_SET_GRID);
        const char *grid = own_grid ? "density" : in->scene->grid;
        vdbio_read_options read = {0};
        read.grid_name = grid[0] ? grid : NULL;
        read.grid_index = own_grid ? 0 : in->scene->grid_index;
        read.warn = d->warn;
        read.warn_user = d->warn_user;
        st = vdbs_volume_load(input, &read, &in->volume, err);
        if (st == VDBS_OK)
            st = vdbs_scene_fit_density(in->scene, &in->volume, err);
        if (st == VDBS_OK && in->scene->light_count == 0)
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "no lights: give --sun, --point or --env (or a --scene)");
        if (st == VDBS_OK && in->mode == VDBS_RENDER_BAKED)
            st = vdbs_ms_grids_load(lit, in->volume.index_to_world, &in->ms, err);
    }
    if (lit)
        vdbio_lit_close(lit);
    if (st == VDBS_OK)
        choose_camera(d, in->scene, &in->volume, &in->camera);
    if (st != VDBS_OK)
        vdbs_render_input_free(in);
    return st;
}

void vdbs_render_input_free(vdbs_render_input *in)
{
    vdbs_ms_grids_free(&in->ms);
    vdbs_volume_free(&in->volume);
    free(in->scene);
    memset(in, 0, sizeof *in);
}

vdbs_status vdbs_render(const vdbs_render_desc *d, vdbs_render_report *report, vdbs_error *err)
{
    memset(report, 0, sizeof *report);
    double t_start = vdbs_now();
    const char *input = NULL;
    vdbs_status st = input_path(d, &input, err);
    if (st == VDBS_OK)
        st = vdbio_check_output(d->output, input, err);
    if (st != VDBS_OK)
        return st;
    vdbs_render_input in;
    if ((st = vdbs_render_open(d, &in, err)) != VDBS_OK)
        return st;
    report->mode = vdbs_render_mode_name(in.mode);
    report->camera = in.camera;
    double t_loaded = vdbs_now();
    if (vdbs_cancelled(d->cancel)) {
        vdbs_render_input_free(&in);
        return vdbs_error_cancelled(err);
    }

    vdbs_camera_frame frame;
    vdbs_image image;
    memset(&image, 0, sizeof image);
    st = vdbs_camera_frame_init(&report->camera, &frame, err);
    if (st == VDBS_OK)
        st = vdbs_image_alloc(&image, report->camera.width, report->camera.height,
                              in.mode == VDBS_RENDER_REFERENCE, err);
    double t_render = vdbs_now();
    if (st == VDBS_OK)
        st = render_image(d, in.mode, &in.volume, &in.ms, in.scene, &frame, &in.march, &image,
                          report, err);
    double t_rendered = vdbs_now();
    if (st == VDBS_OK)
        st = vdbs_image_write_cancel(d->output, &image, d->exposure, d->cancel, err);
    double t_written = vdbs_now();
    /* A cancel after the rename: the new picture stays, the caller still hears of it. */
    if (st == VDBS_OK && vdbs_cancelled(d->cancel))
        st = vdbs_error_cancelled(err);

    if (st == VDBS_OK) {
        snprintf(report->grid, sizeof report->grid, "%s", in.volume.info.name);
        snprintf(report->quality, sizeof report->quality, "%s", in.scene->quality);
        report->width = report->camera.width;
        report->height = report->camera.height;
        report->sky_directions = in.march.sky_directions;
        report->step_voxels = in.march.step_voxels;
        memcpy(report->camera_up, frame.up, sizeof report->camera_up);
        report->seconds_load = t_loaded - t_start;
        report->seconds_render = t_rendered - t_render;
        report->seconds_write = t_written - t_rendered;
        report->seconds_total = vdbs_now() - t_start;
    }
    vdbs_image_free(&image);
    vdbs_render_input_free(&in);
    return st;
}
