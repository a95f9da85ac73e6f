#include "vdbscatter/render.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/single.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"
#include "vs_phase.h"
#include "vs_render.h"

#define VDBS_PI 3.14159265358979323846

/* Pixels per GPU dispatch chunk: short enough for a display driver's watchdog on real
 * GPUs, large enough to keep llvmpipe's threads busy. */
#define RENDER_GPU_CHUNK 4096u

static const char *const ms_grid_names[4] = {"ms", "ms_l1x", "ms_l1y", "ms_l1z"};

static int ms_present(const vdbs_ms_grids *ms)
{
    return ms && ms->ms && ms->l1x && ms->l1y && ms->l1z;
}

void vdbs_ms_grids_free(vdbs_ms_grids *grids)
{
    if (!grids)
        return;
    free(grids->ms);
    free(grids->l1x);
    free(grids->l1y);
    free(grids->l1z);
    memset(grids, 0, sizeof *grids);
}

static int same_transform(const vdbio_transform *a, const double b[3][4])
{
    double scale = 0.0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            scale = fmax(scale, fabs(b[r][c]));
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            if (!(fabs(a->m[r][c] - b[r][c]) <= 1e-9 * scale))
                return 0;
    return 1;
}

vdbs_status vdbs_ms_grids_load(const vdbio_lit *lit, const double index_to_world[3][4],
                               vdbs_ms_grids *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    uint32_t **bufs[4] = {&out->ms, &out->l1x, &out->l1y, &out->l1z};
    size_t *sizes[4] = {&out->ms_size, &out->l1x_size, &out->l1y_size, &out->l1z_size};
    for (int i = 0; i < 4; ++i) {
        vdbio_transform t;
        vdbs_status st = vdbio_lit_transform(lit, ms_grid_names[i], &t, err);
        if (st == VDBS_OK && !same_transform(&t, index_to_world))
            st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                "grid '%s' is not on the density grid's transform",
                                ms_grid_names[i]);
        void *buffer = NULL;
        if (st == VDBS_OK)
            st = vdbio_lit_vec3_nanovdb(lit, ms_grid_names[i], &buffer, sizes[i], err);
        if (st != VDBS_OK) {
            vdbs_ms_grids_free(out);
            return st;
        }
        *bufs[i] = buffer;
    }
    return VDBS_OK;
}

int vdbs_render_quality(const char *quality, vdbs_march_options *options)
{
    static const char *const names[] = {"low", "medium", "high", "ultra"};
    for (int q = 0; q < 4; ++q) {
        if (quality && strcmp(quality, names[q]) == 0) {
            options->sky_directions = 16 << (2 * q);
            options->step_voxels = 1.0f / (float)(1 << q);
            return 1;
        }
    }
    return 0;
}

static void set_entry(float *e, double x, double y, double z, double w)
{
    e[0] = (float)x;
    e[1] = (float)y;
    e[2] = (float)z;
    e[3] = (float)w;
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

vdbs_status vdbs_render_table(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                              const vdbs_scene *scene, const vdbs_camera_frame *frame,
                              const vdbs_march_options *options, float **data, size_t *entries,
                              vdbs_error *err)
{
    *data = NULL;
    *entries = 0;
    if (!(options->step_voxels > 0.0f) || !isfinite(options->step_voxels) ||
        options->sky_directions < 1)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "render: bad march options (step %g voxels, %d sky directions)",
                              (double)options->step_voxels, options->sky_directions);
    int lights = 0, has_sky = 0;
    double sky[3];
    vdbs_status st = vdbs_scene_light_summary(scene, sky, &has_sky, &lights, err);
    if (st != VDBS_OK)
        return st;
    int k = has_sky ? options->sky_directions : 0;
    size_t n = VS_RENDER_HEADER + 3 * (size_t)lights + 2 * (size_t)k;
    float *t = calloc(n, 4 * sizeof *t);
    double *dirs = k ? malloc(3 * sizeof *dirs * (size_t)k) : NULL;
    if (!t || (k && !dirs)) {
        free(t);
        free(dirs);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the render table");
    }

    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    const double(*m)[4] = volume->index_to_world;
    const double(*inv)[4] = volume->world_to_index;
    set_entry(t, lights, k, scene->density_scale, 0.5 * volume->mean_voxel_size);
    for (int r = 0; r < 3; ++r) {
        set_entry(t + 4 * (1 + r), m[r][0], m[r][1], m[r][2], 0.0);
        set_entry(t + 4 * (11 + r), inv[r][0], inv[r][1], inv[r][2], 0.0);
    }
    set_entry(t + 4 * 4, lo[0], lo[1], lo[2], options->step_voxels);
    set_entry(t + 4 * 5, hi[0], hi[1], hi[2], ms_present(ms) ? 1.0 : 0.0);
    set_entry(t + 4 * 6, scene->albedo[0], scene->albedo[1], scene->albedo[2], scene->g);
    set_entry(t + 4 * 7, sky[0], sky[1], sky[2], 0.0);
    if (k > 0) {
        double w = 4.0 * VDBS_PI / k;
        set_entry(t + 4 * 8, sky[0] * w, sky[1] * w, sky[2] * w, 0.0);
    }
    if (ms_present(ms)) {
        uint64_t offsets[4];
        ms_offsets(volume, ms, offsets);
        uint64_t units[4];
        for (int i = 0; i < 4; ++i) {
            units[i] = offsets[i] / 32u;
            if (units[i] >> 40) {
                free(t);
                free(dirs);
                return vdbs_error_set(err, VDBS_ERR_INPUT, "lit grids too large to address");
            }
        }
        set_entry(t + 4 * 9, (double)(units[0] >> 16), (double)(units[0] & 0xffffu),
                  (double)(units[1] >> 16), (double)(units[1] & 0xffffu));
        set_entry(t + 4 * 10, (double)(units[2] >> 16), (double)(units[2] & 0xffffu),
                  (double)(units[3] >> 16), (double)(units[3] & 0xffffu));
    }
    double origin[3];
    vdbs_volume_index_point(volume, frame->origin, origin);
    set_entry(t + 4 * 14, origin[0], origin[1], origin[2], frame->width);
    set_entry(t + 4 * 15, frame->forward[0], frame->forward[1], frame->forward[2], frame->height);
    set_entry(t + 4 * 16, frame->right[0] * frame->tan_half_x, frame->right[1] * frame->tan_half_x,
              frame->right[2] * frame->tan_half_x, 0.0);
    set_entry(t + 4 * 17, frame->up[0] * frame->tan_half_y, frame->up[1] * frame->tan_half_y,
              frame->up[2] * frame->tan_half_y, 0.0);

    float *e = t + 4 * VS_RENDER_HEADER;
    for (int i = 0; i < scene->light_count; ++i) {
        const vdbs_light *light = &scene->lights[i];
        double v[3];
        if (light->type == VDBS_LIGHT_SUN) {
            double u[3];
            if (!vdbs_volume_sun_step(volume, light->direction, u, v)) {
                free(t);
                free(dirs);
                return vdbs_error_set(err, VDBS_ERR_INPUT, "sun %d has a zero direction", i);
            }
            set_entry(e, VS_RENDER_LIGHT_SUN, v[0], v[1], v[2]);
            set_entry(e + 4, u[0], u[1], u[2], 0.0);
        } else if (light->type == VDBS_LIGHT_POINT) {
            vdbs_volume_index_point(volume, light->position, v);
            set_entry(e, VS_RENDER_LIGHT_POINT, v[0], v[1], v[2]);
            set_entry(e + 4, light->position[0], light->position[1], light->position[2], 0.0);
        } else {
            continue;
        }
        set_entry(e + 8, light->color[0], light->color[1], light->color[2], 0.0);
        e += 12;
    }
    if (k > 0) {
        vdbs_sphere_directions(k, dirs);
        for (int d = 0; d < k; ++d) {
            double v[3];
            vdbs_volume_index_vector(volume, dirs + 3 * d, v);
            set_entry(e + 8 * d, v[0], v[1], v[2], 0.0);
            set_entry(e + 8 * d + 4, dirs[3 * d], dirs[3 * d + 1], dirs[3 * d + 2], 0.0);
        }
    }
    free(dirs);
    *data = t;
    *entries = n;
    return VDBS_OK;
}

vdbs_status vdbs_render_buffer(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                               uint32_t **buffer, size_t *size, int *owned, vdbs_error *err)
{
    if (!ms_present(ms)) {
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

vdbs_status vdbs_render_march_cpu(const vdbs_volume *volume, const vdbs_ms_grids *ms,
                                  const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                  const vdbs_march_options *options, vdbs_image *image,
                                  vdbs_error *err)
{
    vdbs_status st = check_image(frame, image, err);
    if (st != VDBS_OK)
        return st;
    float *table = NULL;
    size_t entries = 0;
    if ((st = vdbs_render_table(volume, ms, scene, frame, options, &table, &entries, err)) !=
        VDBS_OK)
        return st;
    uint32_t *grids = NULL;
    size_t grids_size = 0;
    int owned = 0;
    if ((st = vdbs_render_buffer(volume, ms, &grids, &grids_size, &owned, err)) != VDBS_OK) {
        free(table);
        return st;
    }
    const vs_vec4 *render_data = (const vs_vec4 *)table;
    pnanovdb_buf_t buf = pnanovdb_make_buf(grids, grids_size / 4);
    const int width = frame->width;
    const int64_t count = (int64_t)frame->width * frame->height;
    float *rgb = image->rgb;
    vdbs_progress *progress = options->progress;
    int64_t done = 0;

#pragma omp parallel
    {
        vs_render_accessors accs = vs_render_accessors_init(render_data, buf);
#pragma omp for schedule(dynamic, 16)
        for (int64_t n = 0; n < count; ++n) {
            pnanovdb_vec3_t L =
                vs_render_pixel(render_data, buf, &accs, (int)(n % width), (int)(n / width));
            rgb[3 * n] = L.x;
            rgb[3 * n + 1] = L.y;
            rgb[3 * n + 2] = L.z;
            int64_t now_done;
#pragma omp atomic capture
            now_done = ++done;
            if (progress && omp_get_thread_num() == 0)
                vdbs_progress_update(progress, (uint64_t)now_done);
        }
    }
    if (owned)
        free(grids);
    free(table);
    return VDBS_OK;
}

/* Words of ray state per pixel in render_march.comp. */
#define STATE_WORDS 16u
/* Canary trip count and the control words of render_march.comp. */
#define CANARY_TRIPS 2u
enum {
    CONTROL_UNITS,
    CONTROL_FIRST,
    CONTROL_CANARY,
    CONTROL_STEP,
    CONTROL_LEFT,
    CONTROL_FAILED,
    CONTROL_WORDS
};

vdbs_status vdbs_render_march_gpu(vdbs_gpu *gpu, const vdbs_volume *volume, const vdbs_ms_grids *ms,
                                  const vdbs_scene *scene, const vdbs_camera_frame *frame,
                                  const vdbs_march_options *options, vdbs_image *image,
                                  vdbs_error *err)
{
    vdbs_status st = check_image(frame, image, err);
    if (st != VDBS_OK)
        return st;
    const vdbs_shader_source *source = vdbs_shader_find("render_march.comp");
    if (!source)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "shader render_march.comp not embedded");
    float *table = NULL;
    size_t entries = 0;
    if ((st = vdbs_render_table(volume, ms, scene, frame, options, &table, &entries, err)) !=
        VDBS_OK)
        return st;
    uint32_t *grids = NULL;
    size_t grids_size = 0;
    int owned = 0;
    if ((st = vdbs_render_buffer(volume, ms, &grids, &grids_size, &owned, err)) != VDBS_OK) {
        free(table);
        return st;
    }
    /* GLSL addresses bytes with 32-bit unsigned integers. */
    if (grids_size > 0xffffffffu)
        st = vdbs_error_set(err, VDBS_ERR_GPU,
                            "%zu bytes of grids exceed the 4 GiB a shader can address; use "
                            "--backend cpu",
                            grids_size);

    const uint64_t count = (uint64_t)frame->width * (uint64_t)frame->height;
    unsigned int program = 0, nano = 0, lights = 0, out = 0, states[2] = {0, 0};
    if (st == VDBS_OK)
        st = vdbs_gpu_program_create(gpu, source, NULL, &program, err);
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_create(gpu, grids_size, grids, &nano, err);
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_create(gpu, entries * 4 * sizeof(float), table, &lights, err);
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_create(gpu, 3 * sizeof(float) * count, NULL, &out, err);
    for (int i = 0; i < 2 && st == VDBS_OK; ++i)
        st = vdbs_gpu_buffer_create(gpu, STATE_WORDS * sizeof(uint32_t) * count, NULL, &states[i],
                                    err);
    if (st == VDBS_OK) {
        vdbs_gpu_buffer_bind(gpu, nano, 0);
        vdbs_gpu_buffer_bind(gpu, lights, 1);
        vdbs_gpu_buffer_bind(gpu, out, 2);
    }
    int64_t units =
        options->gpu_units > 0 ? options->gpu_units : vdbs_volume_gpu_marches_per_pass(volume);
    int first = 1, in = 0;
    while (st == VDBS_OK) {
        uint32_t control[CONTROL_WORDS] = {0};
        control[CONTROL_UNITS] = (uint32_t)(units < 0x7fffffff ? units : 0x7fffffff);
        control[CONTROL_FIRST] = (uint32_t)first;
        control[CONTROL_CANARY] = CANARY_TRIPS;
        control[CONTROL_STEP] = 1u;
        unsigned int control_buffer = 0;
        st = vdbs_gpu_buffer_create(gpu, sizeof control, control, &control_buffer, err);
        if (st != VDBS_OK)
            break;
        vdbs_gpu_buffer_bind(gpu, states[in], 3);
        vdbs_gpu_buffer_bind(gpu, states[1 - in], 4);
        vdbs_gpu_buffer_bind(gpu, control_buffer, 5);
        st = vdbs_gpu_dispatch_items(gpu, program, count, 64, RENDER_GPU_CHUNK, NULL, NULL, err);
        if (st == VDBS_OK)
            st = vdbs_gpu_buffer_read(gpu, control_buffer, 0, sizeof control, control, err);
        vdbs_gpu_buffer_destroy(gpu, control_buffer);
        if (st != VDBS_OK)
            break;
        if (control[CONTROL_FAILED]) {
            /* The states in `in` are untouched: run the same pass with fewer units. */
            if (units == 1)
                st = vdbs_error_set(err, VDBS_ERR_GPU,
                                    "a single march exceeds the GPU driver's loop limit; use "
                                    "--backend cpu");
            units = units / 2 > 0 ? units / 2 : 1;
            continue;
        }
        first = 0;
        in = 1 - in;
        if (options->progress)
            vdbs_progress_update(options->progress, count - control[CONTROL_LEFT]);
        if (control[CONTROL_LEFT] == 0)
            break;
    }
    if (st == VDBS_OK)
        st = vdbs_gpu_buffer_read(gpu, out, 0, 3 * sizeof(float) * count, image->rgb, err);
    for (int i = 0; i < 2; ++i)
        vdbs_gpu_buffer_destroy(gpu, states[i]);
    vdbs_gpu_buffer_destroy(gpu, out);
    vdbs_gpu_buffer_destroy(gpu, lights);
    vdbs_gpu_buffer_destroy(gpu, nano);
    if (program)
        vdbs_gpu_program_destroy(gpu, program);
    if (owned)
        free(grids);
    free(table);
    return st;
}
