#include "vdbscatter/volume.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int vdbs_affine_invert(const double m[3][4], double inv[3][4])
{
    double a = m[0][0], b = m[0][1], c = m[0][2];
    double d = m[1][0], e = m[1][1], f = m[1][2];
    double g = m[2][0], h = m[2][1], i = m[2][2];
    double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return 0;
    double r = 1.0 / det;
    inv[0][0] = (e * i - f * h) * r;
    inv[0][1] = (c * h - b * i) * r;
    inv[0][2] = (b * f - c * e) * r;
    inv[1][0] = (f * g - d * i) * r;
    inv[1][1] = (a * i - c * g) * r;
    inv[1][2] = (c * d - a * f) * r;
    inv[2][0] = (d * h - e * g) * r;
    inv[2][1] = (b * g - a * h) * r;
    inv[2][2] = (a * e - b * d) * r;
    for (int row = 0; row < 3; ++row)
        inv[row][3] = -(inv[row][0] * m[0][3] + inv[row][1] * m[1][3] + inv[row][2] * m[2][3]);
    return 1;
}

vdbs_status vdbs_volume_from_density(vdbio_density *density, vdbs_volume *volume, vdbs_error *err)
{
    memset(volume, 0, sizeof *volume);
    volume->density = density;
    volume->info = *vdbio_density_get_info(density);
    memcpy(volume->index_to_world, volume->info.transform.m, sizeof volume->index_to_world);
    if (!vdbs_affine_invert(volume->index_to_world, volume->world_to_index)) {
        vdbs_volume_free(volume);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "grid '%s' has a singular transform",
                              volume->info.name);
    }
    volume->mean_voxel_size =
        (volume->info.voxel_size[0] + volume->info.voxel_size[1] + volume->info.voxel_size[2]) /
        3.0;
    void *nano = NULL;
    vdbs_status st = vdbio_density_to_nanovdb(density, &nano, &volume->nano_size, err);
    if (st != VDBS_OK) {
        vdbs_volume_free(volume);
        return st;
    }
    volume->nano = nano;
    st = vdbio_density_output_coords(density, 1, &volume->coords, &volume->coord_count, err);
    if (st != VDBS_OK) {
        vdbs_volume_free(volume);
        return st;
    }
    return VDBS_OK;
}

vdbs_status vdbs_volume_load(const char *path, const vdbio_read_options *options,
                             vdbs_volume *volume, vdbs_error *err)
{
    vdbio_density *density = NULL;
    memset(volume, 0, sizeof *volume);
    vdbs_status st = vdbio_density_read(path, options, &density, err);
    if (st != VDBS_OK)
        return st;
    return vdbs_volume_from_density(density, volume, err);
}

void vdbs_volume_node_counts(const vdbs_volume *volume, int64_t counts[3])
{
    static const int shift[3] = {3, 7, 12}; /* log2 of a node's side in voxels */
    for (int level = 0; level < 3; ++level) {
        int64_t count = 0;
        int32_t last[3] = {0, 0, 0};
        for (size_t v = 0; v < volume->coord_count; ++v) {
            int32_t at[3];
            for (int a = 0; a < 3; ++a)
                at[a] = volume->coords[3 * v + a] >> shift[level]; /* floor division */
            count += v == 0 || at[0] != last[0] || at[1] != last[1] || at[2] != last[2];
            memcpy(last, at, sizeof last);
        }
        counts[level] = count;
    }
}

int64_t vdbs_volume_leaf_count(const vdbs_volume *volume)
{
    int64_t counts[3];
    vdbs_volume_node_counts(volume, counts);
    return counts[0];
}

void vdbs_volume_free(vdbs_volume *volume)
{
    if (!volume)
        return;
    vdbio_density_free(volume->density);
    free(volume->nano);
    free(volume->coords);
    memset(volume, 0, sizeof *volume);
}

void vdbs_volume_index_vector(const vdbs_volume *volume, const double world[3], double index[3])
{
    for (int r = 0; r < 3; ++r)
        index[r] = volume->world_to_index[r][0] * world[0] +
                   volume->world_to_index[r][1] * world[1] +
                   volume->world_to_index[r][2] * world[2];
}

void vdbs_volume_index_point(const vdbs_volume *volume, const double world[3], double index[3])
{
    vdbs_volume_index_vector(volume, world, index);
    for (int r = 0; r < 3; ++r)
        index[r] += volume->world_to_index[r][3];
}

void vdbs_volume_world_point(const vdbs_volume *volume, const double index[3], double world[3])
{
    for (int r = 0; r < 3; ++r)
        world[r] = volume->index_to_world[r][0] * index[0] +
                   volume->index_to_world[r][1] * index[1] +
                   volume->index_to_world[r][2] * index[2] + volume->index_to_world[r][3];
}

int vdbs_volume_sun_step(const vdbs_volume *volume, const double direction[3], double unit[3],
                         double towards[3])
{
    const double *d = direction;
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(len > 0.0) || !isfinite(len))
        return 0;
    double u[3] = {d[0] / len, d[1] / len, d[2] / len};
    double back[3] = {-u[0], -u[1], -u[2]};
    vdbs_volume_index_vector(volume, back, towards);
    if (unit)
        memcpy(unit, u, sizeof u);
    return 1;
}

void vdbs_volume_support_box(const vdbs_volume *volume, float lo[3], float hi[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = (float)(volume->info.bbox_min[a] - 1);
        hi[a] = (float)(volume->info.bbox_max[a] + 1);
    }
}

int vdbs_volume_gpu_marches_per_pass(const vdbs_volume *volume)
{
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    double cells = (double)(hi[0] - lo[0]) + (double)(hi[1] - lo[1]) + (double)(hi[2] - lo[2]);
    double marches = 32000.0 / (cells + 10.0);
    return marches < 1.0 ? 1 : (int)marches;
}

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

void vdbs_volume_thickness(const vdbs_volume *volume, double density_scale, vdbs_thickness *out)
{
    memset(out, 0, sizeof *out);
    out->voxel_max = volume->info.value_max * density_scale * volume->mean_voxel_size;
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    pnanovdb_vec3_t box_lo = vs_vec3(lo[0], lo[1], lo[2]);
    pnanovdb_vec3_t box_hi = vs_vec3(hi[0], hi[1], hi[2]);
    for (int axis = 0; axis < 3; ++axis) {
        int u = (axis + 1) % 3, v = (axis + 2) % 3;
        double world_len = volume->info.voxel_size[axis];
        double sum = 0.0;
        for (int a = 0; a < 64; ++a) {
            for (int b = 0; b < 64; ++b) {
                float p[3];
                p[axis] = lo[axis];
                p[u] = lo[u] + (hi[u] - lo[u]) * (a + 0.5f) / 64.0f;
                p[v] = lo[v] + (hi[v] - lo[v]) * (b + 0.5f) / 64.0f;
                float d[3] = {0.0f, 0.0f, 0.0f};
                d[axis] = (float)(1.0 / world_len);
                float tau = vs_optical_depth(buf, &acc, vs_vec3(p[0], p[1], p[2]),
                                             vs_vec3(d[0], d[1], d[2]), VS_T_INFINITE, box_lo,
                                             box_hi, (float)density_scale);
                if (tau > 0.0f) {
                    sum += tau;
                    out->axis_max[axis] = fmax(out->axis_max[axis], tau);
                    out->axis_rays_hit[axis]++;
                }
            }
        }
        out->axis_mean[axis] = out->axis_rays_hit[axis] ? sum / out->axis_rays_hit[axis] : 0.0;
    }
}

double vdbs_thickness_mean(const vdbs_thickness *t)
{
    double sum = 0.0;
    int axes = 0;
    for (int a = 0; a < 3; ++a)
        if (t->axis_rays_hit[a] > 0) {
            sum += t->axis_mean[a];
            ++axes;
        }
    return axes ? sum / axes : 0.0;
}

void vdbs_volume_support_corners(const vdbs_volume *volume, double corners[8][3])
{
    float lo[3], hi[3];
    vdbs_volume_support_box(volume, lo, hi);
    for (int c = 0; c < 8; ++c) {
        double idx[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]};
        vdbs_volume_world_point(volume, idx, corners[c]);
    }
}

/* The world axis-aligned bounds of the support box's corners. */
static void support_bounds(const double corners[8][3], double lo[3], double hi[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = HUGE_VAL;
        hi[a] = -HUGE_VAL;
    }
    for (int c = 0; c < 8; ++c)
        for (int a = 0; a < 3; ++a) {
            lo[a] = fmin(lo[a], corners[c][a]);
            hi[a] = fmax(hi[a], corners[c][a]);
        }
}

double vdbs_volume_support_extent(const vdbs_volume *volume)
{
    double corners[8][3], lo[3], hi[3];
    vdbs_volume_support_corners(volume, corners);
    support_bounds(corners, lo, hi);
    return fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
}

void vdbs_volume_support_distances(const vdbs_volume *volume, const double p[3], double *near,
                                   double *far)
{
    double corners[8][3], lo[3], hi[3];
    vdbs_volume_support_corners(volume, corners);
    support_bounds(corners, lo, hi);
    *far = 0.0;
    for (int c = 0; c < 8; ++c) {
        double d2 = 0.0;
        for (int a = 0; a < 3; ++a)
            d2 += (corners[c][a] - p[a]) * (corners[c][a] - p[a]);
        *far = fmax(*far, sqrt(d2));
    }
    double n2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        double d = p[a] < lo[a] ? lo[a] - p[a] : (p[a] > hi[a] ? p[a] - hi[a] : 0.0);
        n2 += d * d;
    }
    *near = sqrt(n2);
}

int vdbs_volume_in_support(const vdbs_volume *volume, const double world[3])
{
    float lo[3], hi[3];
    double idx[3];
    vdbs_volume_support_box(volume, lo, hi);
    vdbs_volume_index_point(volume, world, idx);
    for (int a = 0; a < 3; ++a)
        if (!(idx[a] >= lo[a] && idx[a] <= hi[a]))
            return 0;
    return 1;
}

double vdbs_volume_voxel_volume(const vdbs_volume *volume)
{
    const double(*m)[4] = volume->index_to_world;
    return fabs(m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]));
}

void vdbs_volume_voxel_point(const vdbs_volume *volume, size_t n, double world[3])
{
    const int32_t *c = volume->coords + 3 * n;
    const double index[3] = {c[0], c[1], c[2]};
    vdbs_volume_world_point(volume, index, world);
}

void vdbs_volume_support_bounds(const vdbs_volume *volume, double lo[3], double hi[3])
{
    double corners[8][3];
    vdbs_volume_support_corners(volume, corners);
    for (int a = 0; a < 3; ++a) {
        lo[a] = hi[a] = corners[0][a];
        for (int c = 1; c < 8; ++c) {
            lo[a] = corners[c][a] < lo[a] ? corners[c][a] : lo[a];
            hi[a] = corners[c][a] > hi[a] ? corners[c][a] : hi[a];
        }
    }
}
