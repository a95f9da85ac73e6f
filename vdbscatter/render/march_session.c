/* The ray-march render's engine: the kernel's render table and grid buffer, the session
 * that keeps grids, lights and light grids between pictures, and the passes over a
 * finished picture (the viewer's fog and interleaved sampling's gather). */
#include "vdbscatter/march_session.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/fog.h"
#include "vdbscatter/lights.h"
#include "vdbscatter/medium.h"

#include "base/vdbs_math.h"
#include "render/image_check.h"

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

/* Byte offsets in the render buffer (density first) of the four ms grids, then of the stored
 * depth grids: 4 + grids->depth_count of them. */
static void grid_offsets(const vdbs_volume *volume, const vdbs_lit_grids *grids, uint64_t *offsets)
{
    uint64_t at = volume->nano_size;
    const size_t ms_sizes[4] = {grids->ms_size, grids->l1x_size, grids->l1y_size, grids->l1z_size};
    for (int i = 0; i < 4 + grids->depth_count; ++i) {
        at = (at + 31u) / 32u * 32u;
        offsets[i] = at;
        at += i < 4 ? ms_sizes[i] : grids->depth[i - 4].size;
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

vdbs_status vdbs_render_table(const vdbs_volume *volume, const vdbs_lit_grids *ms,
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
    int with_ms = vdbs_lit_grids_have_ms(ms);
    vdbs_table_put(t + 4 * VS_RENDER_OFF_MARCH, options->step_voxels, with_ms ? 1.0 : 0.0, 0.0,
                   0.0);
    if (with_ms) {
        uint64_t offsets[4] = {0, 0, 0, 0};
        vdbs_lit_grids only_ms = *ms;
        only_ms.depth_count = 0;
        grid_offsets(volume, &only_ms, offsets);
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

vdbs_status vdbs_render_buffer(const vdbs_volume *volume, const vdbs_lit_grids *grids,
                               uint32_t **buffer, size_t *size, int *owned, vdbs_error *err)
{
    int depths = grids ? grids->depth_count : 0;
    if (!vdbs_lit_grids_have_ms(grids) && depths == 0) {
        *buffer = volume->nano;
        *size = volume->nano_size;
        *owned = 0;
        return VDBS_OK;
    }
    uint64_t *offsets = malloc(sizeof *offsets * (size_t)(4 + depths));
    if (!offsets)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for grid offsets");
    grid_offsets(volume, grids, offsets);
    size_t total = (size_t)offsets[3] + grids->l1z_size;
    if (depths)
        total = (size_t)offsets[3 + depths] + grids->depth[depths - 1].size;
    uint32_t *b = aligned_alloc(32, (total + 31u) / 32u * 32u);
    if (!b) {
        free(offsets);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %zu bytes of grids", total);
    }
    /* Each byte written once: the grids, and zeros only in the gaps between them (a buffer
     * of 256 sky depths is tens of MB). */
    const size_t padded = (total + 31u) / 32u * 32u;
    memcpy(b, volume->nano, volume->nano_size);
    size_t end = volume->nano_size;
    const uint32_t *src[4] = {grids->ms, grids->l1x, grids->l1y, grids->l1z};
    const size_t sizes[4] = {grids->ms_size, grids->l1x_size, grids->l1y_size, grids->l1z_size};
    for (int i = 0; i < 4 + depths; ++i) {
        const void *from = i < 4 ? src[i] : grids->depth[i - 4].grid;
        const size_t bytes = i < 4 ? (src[i] ? sizes[i] : 0) : grids->depth[i - 4].size;
        memset((char *)b + end, 0, (size_t)offsets[i] - end);
        if (bytes)
            memcpy((char *)b + offsets[i], from, bytes);
        end = (size_t)offsets[i] + bytes;
    }
    memset((char *)b + end, 0, padded - end);
    free(offsets);
    *buffer = b;
    *size = total;
    *owned = 1;
    return VDBS_OK;
}

/* Pixel n of an rgb picture. */
static void put_pixel(float *rgb, uint64_t n, pnanovdb_vec3_t L)
{
    rgb[3 * n] = L.x;
    rgb[3 * n + 1] = L.y;
    rgb[3 * n + 2] = L.z;
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
        put_pixel(job->rgb, n, L);
    }
}

/* What a session keeps between pictures: everything but the camera. On the GPU the
 * grids, lights and light grids stay resident under the runner's ids. */
struct vdbs_march_session {
    vdbs_runner *runner;
    const vdbs_volume *volume;
    const vdbs_lit_grids *ms;   /* NULL without ms grids */
    const vdbs_lit_grids *lit;  /* the caller's grids: ms and the stored depths */
    vdbs_march_options options; /* as given to create (the lights' settings) */
    uint32_t *grids;            /* density, ms grids, stored depths (vdbs_render_buffer) */
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
    int stored; /* the light grids are the lit VDB's stored depths */
    /* vdbs_march_session_set_ms: per ms grid (ms, l1x, l1y, l1z) and output voxel the byte
     * offset of its value in `grids`, or UINT64_MAX where the grid has no leaf there */
    uint64_t *ms_at;
    uint64_t id_grids, id_lights, id_light_grids, id_env, id_shadows;
};

void vdbs_march_session_tables(const vdbs_march_session *s, vdbs_march_tables *out)
{
    out->lights = s->lights.packed;
    out->light_floats = s->lights.packed_entries * 4;
    out->medium = s->medium;
    out->medium_floats = sizeof s->medium / sizeof s->medium[0];
    /* The stored depths' kind needs the render's buffer: no tables for the surfaces. */
    int swept = !s->options.s1_march && !s->stored;
    out->light_grids = swept ? s->light_grids.words : NULL;
    out->light_grid_words = swept ? s->light_grids.word_count : 0;
}

void vdbs_march_session_set_shadows(vdbs_march_session *s, const float *table, size_t floats)
{
    vdbs_runner_release(s->runner, s->id_shadows);
    s->shadows = table && floats >= VS_SHADOW_OFF_ENTRIES ? table : s->no_shadows;
    s->shadow_floats = table && floats >= VS_SHADOW_OFF_ENTRIES ? floats : VS_SHADOW_OFF_ENTRIES;
    s->id_shadows = vdbs_runner_resident_id(s->runner);
}

static vdbs_status session_scene(vdbs_march_session *s, const vdbs_scene *scene, int stored,
                                 vdbs_error *err);

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
    free(session->ms_at);
    free(session);
}

static uint32_t float_word(double value)
{
    float f = (float)value;
    uint32_t w;
    memcpy(&w, &f, sizeof w);
    return w;
}

/* The light-grid set of a lit VDB's stored depths: one VS_LGRID_VOXEL header per light,
 * pointing at its float grid in the render buffer. The depths must be the table's lights. */
static vdbs_status stored_light_grids(vdbs_march_session *s, vdbs_error *err)
{
    const vdbs_lit_grids *lit = s->lit;
    int n = lit->depth_count;
    if (lit->depth_direct != s->lights.direct_count ||
        n - lit->depth_direct != s->lights.ordinate_count)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "the lit VDB stores depths for %d direct light%s and %d sky "
                              "ordinate%s, the scene has %d and %d: render it with --relight",
                              lit->depth_direct, lit->depth_direct == 1 ? "" : "s",
                              n - lit->depth_direct, n - lit->depth_direct == 1 ? "" : "s",
                              s->lights.direct_count, s->lights.ordinate_count);
    size_t words = VS_LGRIDS_OFF_HEADERS + (size_t)n * VS_LGRID_WORDS;
    for (int i = 0; i < n; ++i)
        words += lit->depth[i].radial ? (size_t)lit->depth[i].shells : 0u;
    uint64_t *offsets = malloc(sizeof *offsets * (size_t)(4 + n));
    uint32_t *w = calloc(words, sizeof *w);
    if (!offsets || !w) {
        free(offsets);
        free(w);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the stored light grids");
    }
    grid_offsets(s->volume, lit, offsets);
    w[VS_LGRIDS_OFF_COUNT] = (uint32_t)n;
    w[VS_LGRIDS_OFF_ACROSS] = VS_LGRID_ACROSS_BILINEAR;
    size_t radii_at = VS_LGRIDS_OFF_HEADERS + (size_t)n * VS_LGRID_WORDS;
    vdbs_status st = VDBS_OK;
    for (int i = 0; i < n && st == VDBS_OK; ++i) {
        const vdbs_lit_depth *d = &lit->depth[i];
        uint32_t *h = w + vs_lgrid_header(i);
        uint64_t unit = offsets[4 + i] / 32u;
        if (unit > 0xffffffffu)
            st = vdbs_error_set(err, VDBS_ERR_INPUT, "lit grids too large to address");
        h[VS_LGRID_OFF_VOXEL_GRID] = (uint32_t)unit;
        if (d->radial) {
            /* the radial grid's header as the sweep writes it: light, texels, shells */
            if (i >= s->lights.direct_count || s->lights.direct[i].type != VDBS_LIGHT_POINT) {
                st = vdbs_error_set(err, VDBS_ERR_INPUT,
                                    "stored depth %d is a point light's, the scene's light is "
                                    "not: render it with --relight",
                                    i);
                break;
            }
            h[VS_LGRID_OFF_KIND] = VS_LGRID_VOXEL_RADIAL;
            h[VS_LGRID_OFF_N] = h[VS_LGRID_OFF_N + 1] = (uint32_t)d->texels;
            h[VS_LGRID_OFF_N + 2] = (uint32_t)d->shells;
            h[VS_LGRID_OFF_RADII] = (uint32_t)radii_at;
            for (int r = 0; r < 3; ++r)
                h[VS_LGRID_OFF_ORIGIN + r] = float_word(s->lights.direct[i].index[r]);
            for (int k = 0; k < d->shells; ++k)
                w[radii_at++] = float_word(d->radii[k]);
            continue;
        }
        h[VS_LGRID_OFF_KIND] = VS_LGRID_VOXEL;
        for (int r = 0; r < 3; ++r) {
            h[VS_LGRID_OFF_ORIGIN + r] = float_word(d->to_grid[r][3]);
            for (int c = 0; c < 3; ++c)
                h[VS_LGRID_OFF_TO_GRID + 3 * r + c] = float_word(d->to_grid[r][c]);
        }
    }
    free(offsets);
    if (st != VDBS_OK) {
        free(w);
        return st;
    }
    s->light_grids.words = w;
    s->light_grids.word_count = words;
    s->light_grids.count = n;
    return VDBS_OK;
}

int64_t vdbs_march_session_bytes(const vdbs_volume *volume, const vdbs_lit_grids *ms,
                                 int64_t pixels)
{
    int64_t bytes = 2 * 3 * (int64_t)sizeof(float) * pixels; /* the gather's `other` and `out` */
    int depths = ms ? ms->depth_count : 0;
    if (!vdbs_lit_grids_have_ms(ms) && depths == 0)
        return bytes; /* the buffer is the volume's own */
    uint64_t *offsets = malloc(sizeof *offsets * (size_t)(4 + depths));
    if (!offsets)
        return bytes;
    grid_offsets(volume, ms, offsets);
    int64_t total = (int64_t)offsets[3] + (int64_t)ms->l1z_size;
    if (depths)
        total = (int64_t)offsets[3 + depths] + (int64_t)ms->depth[depths - 1].size;
    free(offsets);
    int64_t headers = VS_LGRIDS_OFF_HEADERS + (int64_t)depths * VS_LGRID_WORDS;
    for (int i = 0; i < depths; ++i)
        headers += ms->depth[i].radial ? ms->depth[i].shells : 0;
    return bytes + (total + 31) / 32 * 32 + (int64_t)sizeof(uint32_t) * headers;
}

vdbs_status vdbs_march_session_create(vdbs_runner *runner, const vdbs_volume *volume,
                                      const vdbs_lit_grids *ms, const vdbs_scene *scene,
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
    s->ms = vdbs_lit_grids_have_ms(ms) ? ms : NULL;
    s->lit = ms;
    s->options = *options;
    vdbs_status st =
        vdbs_render_buffer(volume, ms, &s->grids, &s->grids_size, &s->grids_owned, err);
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
        st = session_scene(s, scene, options->stored_depths && ms && ms->depth_count > 0, err);
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
    return session_scene(s, scene, 0, err);
}

/* Where set_ms writes: per ms grid and output voxel the byte offset of its value in the
 * session's buffer (a Vec3f leaf value), found once. A voxel the grid has no leaf for (a
 * tile or the background, shared with its neighbours) is left alone. */
static vdbs_status ms_addresses(vdbs_march_session *s, vdbs_error *err)
{
    const vdbs_volume *volume = s->volume;
    const int64_t n = (int64_t)volume->coord_count;
    s->ms_at = malloc(sizeof *s->ms_at * 4 * (size_t)(n > 0 ? n : 1));
    if (!s->ms_at)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for %lld voxels", (long long)n);
    vdbs_lit_grids only_ms = *s->ms;
    only_ms.depth_count = 0;
    uint64_t offsets[4];
    grid_offsets(volume, &only_ms, offsets);
    const size_t sizes[4] = {s->ms->ms_size, s->ms->l1x_size, s->ms->l1y_size, s->ms->l1z_size};
    for (int g = 0; g < 4; ++g) {
        pnanovdb_buf_t buf = pnanovdb_make_buf(s->grids + offsets[g] / 4, sizes[g] / 4);
        pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
        uint64_t *at = s->ms_at + (size_t)g * (size_t)n;
        for (int64_t v = 0; v < n; ++v) {
            const int32_t *c = volume->coords + 3 * v;
            pnanovdb_coord_t ijk = vs_coord(c[0], c[1], c[2]);
            pnanovdb_uint32_t level = 0;
            pnanovdb_address_t a = pnanovdb_readaccessor_get_value_address_and_level(
                PNANOVDB_GRID_TYPE_VEC3F, buf, &acc, &ijk, &level);
            at[v] = level == 0 ? offsets[g] + a.byte_offset : UINT64_MAX;
        }
    }
    return VDBS_OK;
}

vdbs_status vdbs_march_session_set_ms(vdbs_march_session *s, const float *ms, float *const ms_l1[3],
                                      vdbs_error *err)
{
    if (!s->ms || !s->grids_owned)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "the render session has no ms grids to set");
    if (!s->ms_at) {
        vdbs_status st = ms_addresses(s, err);
        if (st != VDBS_OK)
            return st;
    }
    const int64_t n = (int64_t)s->volume->coord_count;
    const float *src[4] = {ms, ms_l1[0], ms_l1[1], ms_l1[2]};
    char *bytes = (char *)s->grids;
    for (int g = 0; g < 4; ++g) {
        const uint64_t *at = s->ms_at + (size_t)g * (size_t)n;
#pragma omp parallel for schedule(static)
        for (int64_t v = 0; v < n; ++v)
            if (at[v] != UINT64_MAX)
                memcpy(bytes + at[v], src[g] + 3 * v, 3 * sizeof(float));
    }
    /* A new resident id: the GPU uploads the buffer again on the next draw. */
    vdbs_runner_release(s->runner, s->id_grids);
    s->id_grids = vdbs_runner_resident_id(s->runner);
    return VDBS_OK;
}

static vdbs_status session_scene(vdbs_march_session *s, const vdbs_scene *scene, int stored,
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
    s->stored = stored;
    if (stored) {
        st = stored_light_grids(s, err);
        if (options->stats)
            memset(&options->stats->grids, 0, sizeof options->stats->grids);
    } else if (!options->s1_march) {
        vdbs_light_grid_desc gd = {options->s1_oversample, 1, 0.0};
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
        put_pixel(job->out, n, L);
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
    vdbs_status st = render_check_image(frame, image, RENDER_IMAGE_MARCH, err);
    if (st != VDBS_OK)
        return st;
    const int block = options->interleave > 1 ? options->interleave : 1;
    if (block > VDBS_MAX_INTERLEAVE)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "interleave block %d beyond %d", block,
                              VDBS_MAX_INTERLEAVE);
    float *table = NULL;
    size_t entries = 0;
    const vdbs_lit_grids *ms = options->no_multiple ? NULL : s->ms;
    if ((st = vdbs_render_table(s->volume, ms, frame, options, &table, &entries, err)) != VDBS_OK)
        return st;
    const int lookups = s->stored || !s->options.s1_march;
    if (lookups)
        table[4 * VS_RENDER_OFF_MARCH + 2] = 1.0f;
    table[4 * VS_RENDER_OFF_WORLD_ORIGIN + 3] = options->backdrop ? 1.0f : 0.0f;
    const float *backdrop = options->backdrop ? options->backdrop : s->no_backdrop;
    const uint32_t *lgrid_words = lookups ? s->light_grids.words : s->no_grids;
    size_t lgrid_bytes =
        lookups ? sizeof *s->light_grids.words * s->light_grids.word_count : sizeof s->no_grids;
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
