#include "vdbscatter/importance.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/camera.h"
#include "vdbscatter/coarse.h"
#include "vdbscatter/pop_engine.h"
#include "vdbscatter/radial.h"
#include "base/vdbs_math.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_phase.h"
#include "vs_pop.h"

/* Sub-rays per texel and axis that seed the frustum grid. */
#define IMPORTANCE_SUBRAYS 4
/* Cells across the largest extent of the coarse medium the projection marches. */
#define IMPORTANCE_MEDIUM_CELLS 16
/* Doubles per scattering cell of the projection: weight, anisotropy, direction, centroid. */
#define IMPORTANCE_SOURCE_WORDS 8
/* Chunks of texels whose seeded importance is summed apart and then added in chunk order: an
 * OpenMP reduction adds in an order set by the threads, and the sum sets the propagation's
 * tolerance, so the map would depend on the thread count. */
#define IMPORTANCE_SEED_CHUNKS 256

/* The camera rays' first-scattered importance per frustum cell, as POP lobes: every pixel's
 * ray carries the same importance per image-plane area, loses albedo (T_in - T_out) of it to
 * scattering in each shell (optical depth by a march through the box-filtered medium, a voxel
 * per step), and the lobe has anisotropy g about the ray (L = power / A(cell)). */
static double seed(const vdbs_radial_frame *f, const vdbs_volume *volume,
                   const vdbs_medium_box *box, const vdbs_scene *scene, float *state)
{
    const int n0 = f->n[0], n1 = f->n[1], n2 = f->n[2], sub = IMPORTANCE_SUBRAYS;
    const double albedo = (scene->albedo[0] + scene->albedo[1] + scene->albedo[2]) / 3.0;
    const double step = volume->mean_voxel_size, g = scene->g;
    const int texels = n0 * n1;
    double part[IMPORTANCE_SEED_CHUNKS] = {0.0};
#pragma omp parallel for schedule(dynamic, 1)
    for (int chunk = 0; chunk < IMPORTANCE_SEED_CHUNKS; ++chunk) {
        double total = 0.0;
        const int first = (int)((int64_t)texels * chunk / IMPORTANCE_SEED_CHUNKS);
        const int end = (int)((int64_t)texels * (chunk + 1) / IMPORTANCE_SEED_CHUNKS);
        for (int t = first; t < end; ++t) {
            for (int p = 0; p < sub * sub; ++p) {
                double d[3];
                vdbs_radial_direction(f, t % n0 + (p % sub + 0.5) / sub,
                                      t / n0 + (p / sub + 0.5) / sub, d);
                const double weight = 1.0 / (sub * sub);
                double tau = 0.0, r = f->radius[0], t_prev = 1.0;
                for (int k = 0; k < n2; ++k) {
                    const double r_end = f->radius[k + 1];
                    while (r < r_end) {
                        double dr = fmin(step, r_end - r), w[3], idx[3];
                        for (int a = 0; a < 3; ++a)
                            w[a] = f->centre[a] + (r + 0.5 * dr) * d[a];
                        vdbs_volume_index_point(volume, w, idx);
                        tau += scene->density_scale * vdbs_medium_box_density(box, idx) * dr;
                        r += dr;
                    }
                    double tr = exp(-tau), lost = albedo * weight * (t_prev - tr);
                    t_prev = tr;
                    float *cell = state + ((int64_t)k * n0 * n1 + t) * VS_POP_STATE_WORDS;
                    for (int ch = 0; ch < 3; ++ch)
                        cell[VS_POP_STATE_L + ch] += (float)lost;
                    total += lost;
                }
            }
        }
        part[chunk] = total;
    }
    double total = 0.0;
    for (int chunk = 0; chunk < IMPORTANCE_SEED_CHUNKS; ++chunk)
        total += part[chunk];
    vdbs_pop_start_lobes(state, vdbs_radial_cells(f), g, 0, f, NULL);
    return 3.0 * total;
}

/* Optical depth from p towards unit w to the edge of the coarse medium (nearest cell). */
static double coarse_depth(const vdbs_coarse_frame *m, const float *sigma, const double p[3],
                           const double w[3])
{
    double x[3], dx[3];
    for (int a = 0; a < 3; ++a) {
        x[a] = ((p[0] - m->origin[0]) * m->axis[a][0] + (p[1] - m->origin[1]) * m->axis[a][1] +
                (p[2] - m->origin[2]) * m->axis[a][2]) /
               m->h;
        dx[a] = w[0] * m->axis[a][0] + w[1] * m->axis[a][1] + w[2] * m->axis[a][2];
    }
    double tau = 0.0;
    for (int s = 0; s < 4 * (m->n[0] + m->n[1] + m->n[2]); ++s) {
        for (int a = 0; a < 3; ++a)
            x[a] += 0.5 * dx[a];
        int i = (int)floor(x[0]), j = (int)floor(x[1]), k = (int)floor(x[2]);
        if (i < 0 || j < 0 || k < 0 || i >= m->n[0] || j >= m->n[1] || k >= m->n[2])
            break;
        tau += 0.5 * m->h * sigma[((int64_t)k * m->n[1] + j) * m->n[0] + i];
    }
    return tau;
}

/* The camera's frustum grid (VDBS_IMPORTANCE_GRID^2 texels) over the volume's support, from
 * a near distance of half a voxel at least. */
static vdbs_status frustum_frame(const vdbs_volume *volume, const vdbs_scene *scene,
                                 vdbs_radial_frame *f, vdbs_error *err)
{
    vdbs_camera_frame camera;
    vdbs_status st = vdbs_camera_frame_init(&scene->camera, &camera, err);
    if (st != VDBS_OK)
        return st;
    double near, far;
    vdbs_volume_support_distances(volume, camera.origin, &near, &far);
    near = fmax(near, 0.5 * volume->mean_voxel_size);
    far = fmax(far, 2.0 * near);
    return vdbs_radial_perspective(&camera, VDBS_IMPORTANCE_GRID, VDBS_IMPORTANCE_GRID, near, far,
                                   f, err);
}

/* The coarse world-aligned medium the projection marches through. */
static void projection_medium(const vdbs_volume *volume, vdbs_coarse_frame *medium)
{
    double corners[8][3];
    vdbs_volume_support_corners(volume, corners);
    const double extent = vdbs_volume_support_extent(volume);
    const double world_axes[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    vdbs_coarse_fit(corners, world_axes, extent / IMPORTANCE_MEDIUM_CELLS, medium);
}

/* The cells that scatter importance, once: weight V sigma_s Phi_W, the lobe's anisotropy,
 * its direction and the cell's centroid (IMPORTANCE_SOURCE_WORDS each); each map texel then
 * sums over these. Returns how many. */
static int64_t scatter_sources(const vdbs_radial_frame *f, const float *state, const float *sigma,
                               double albedo, double *scatter)
{
    const int64_t cells = vdbs_radial_cells(f), texels = (int64_t)f->n[0] * f->n[1];
    int64_t sources = 0;
    for (int64_t c = 0; c < cells; ++c) {
        const float *cell = state + c * VS_POP_STATE_WORDS;
        const double phi = cell[VS_POP_STATE_ACC_L];
        if (!(phi > 0.0) || !(sigma[c] > 0.0))
            continue;
        double *src = scatter + sources++ * IMPORTANCE_SOURCE_WORDS;
        src[0] = vdbs_radial_cell_volume(f, c) * sigma[c] * albedo * phi;
        src[1] = fmin(fmax(cell[VS_POP_STATE_ACC_LA] / phi, -0.99), 0.99);
        memcpy(src + 2, f->dir + 3 * (c % texels), 3 * sizeof *src);
        vdbs_radial_cell_centroid(f, c, src + 5);
    }
    return sources;
}

/* Every texel of the map: the importance the sources scatter towards its direction,
 * attenuated through the coarse medium (grey, in the red channel). */
static void project_sources(const double *scatter, int64_t sources, const vdbs_coarse_frame *medium,
                            const float *medium_sigma, vdbs_envmap *map)
{
    const int w = map->width, h = map->height;
#pragma omp parallel for schedule(dynamic, 1)
    for (int texel = 0; texel < w * h; ++texel) {
        double dir[3], m = 0.0;
        vdbs_envmap_direction(map, texel % w, texel / w, dir);
        for (int64_t q = 0; q < sources; ++q) {
            const double *src = scatter + q * IMPORTANCE_SOURCE_WORDS, *d = src + 2;
            const double mu = dir[0] * d[0] + dir[1] * d[1] + dir[2] * d[2];
            m += src[0] * vs_hg_eval_d(src[1], 1.0 - mu) *
                 exp(-coarse_depth(medium, medium_sigma, src + 5, dir));
        }
        map->rgb[3 * texel] = (float)m;
    }
}

/* The map relative to its mean over the sphere, over a floor of VDBS_IMPORTANCE_FLOOR, in
 * all three channels (1 everywhere when nothing scatters). */
static void normalize_map(vdbs_envmap *map)
{
    const int w = map->width, h = map->height;
    double mean = 0.0;
    for (int texel = 0; texel < w * h; ++texel)
        mean += map->rgb[3 * texel] * vdbs_envmap_texel_solid_angle(map, texel % w, texel / w);
    mean /= 4.0 * VDBS_PI;
    for (int texel = 0; texel < w * h; ++texel) {
        float v = mean > 0.0 ? (float)(VDBS_IMPORTANCE_FLOOR +
                                       (1.0 - VDBS_IMPORTANCE_FLOOR) * map->rgb[3 * texel] / mean)
                             : 1.0f;
        map->rgb[3 * texel] = map->rgb[3 * texel + 1] = map->rgb[3 * texel + 2] = v;
    }
}

vdbs_status vdbs_importance_map(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, const vdbs_medium_box *box,
                                vdbs_envmap *map, vdbs_importance_stats *stats, vdbs_error *err)
{
    memset(map, 0, sizeof *map);
    memset(stats, 0, sizeof *stats);
    if (!scene->camera.present)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--pop-importance needs a camera (--camera or camera in --scene)");
    vdbs_radial_frame f;
    vdbs_status st = frustum_frame(volume, scene, &f, err);
    if (st != VDBS_OK)
        return st;
    vdbs_coarse_frame medium;
    projection_medium(volume, &medium);
    const int64_t cells = vdbs_radial_cells(&f), medium_cells = vdbs_coarse_cells(&medium);
    const double albedo3[3] = {scene->albedo[0], scene->albedo[1], scene->albedo[2]};
    const double albedo = (albedo3[0] + albedo3[1] + albedo3[2]) / 3.0;
    const double grey[3] = {albedo, albedo, albedo};
    const vdbs_pop_transport transport = {0};
    size_t words = 0;
    uint32_t *params = vdbs_pop_radial_params(&f, scene->g, grey, &transport, &words);
    float *state = calloc((size_t)cells * VS_POP_STATE_WORDS, sizeof *state);
    float *sigma = malloc(sizeof *sigma * (size_t)cells);
    float *medium_sigma = malloc(sizeof *medium_sigma * (size_t)medium_cells);
    double *scatter = malloc(sizeof *scatter * IMPORTANCE_SOURCE_WORDS * (size_t)cells);
    const int w = VDBS_IMPORTANCE_MAP_WIDTH, h = VDBS_IMPORTANCE_MAP_HEIGHT;
    map->data = calloc(3 * (size_t)w * h, sizeof *map->data);
    if (!params || !state || !sigma || !medium_sigma || !scatter || !map->data) {
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the importance grid");
        goto done;
    }
    map->width = w;
    map->height = h;
    map->rgb = map->data;
    map->bytes = sizeof *map->data * 3 * (size_t)w * h;
    stats->cells = cells;
    double t0 = vdbs_now();
    vdbs_radial_sigma(&f, volume, box, scene->density_scale, 0.0, sigma);
    const double seeded = seed(&f, volume, box, scene, state);
    double left = 0.0;
    if (seeded > 0.0)
        st =
            vdbs_pop_propagate(runner, params, words, sigma, cells, state, 4 * VDBS_IMPORTANCE_GRID,
                               1e-3 * seeded, &stats->iterations, &left, err);
    double t1 = vdbs_now();
    stats->seconds_propagate = t1 - t0;
    if (st != VDBS_OK)
        goto done;
    vdbs_coarse_sigma(&medium, volume, box, scene->density_scale, medium_sigma);
    project_sources(scatter, scatter_sources(&f, state, sigma, albedo, scatter), &medium,
                    medium_sigma, map);
    normalize_map(map);
    stats->seconds_project = vdbs_now() - t1;
done:
    if (st != VDBS_OK)
        vdbs_envmap_free(map);
    free(params);
    free(state);
    free(sigma);
    free(medium_sigma);
    free(scatter);
    vdbs_radial_free(&f);
    return st;
}
