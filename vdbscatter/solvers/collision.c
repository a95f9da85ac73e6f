#include "vdbscatter/collision.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

/* Voxels thinner than the first optical thickness keep the point rule, those thicker than the
 * second take the faces' average, linearly between (sigma_t of the densest of the 3 x 3 x 3
 * voxels around times the mean voxel side): the point rule is off by sinh(x / 2) / (x / 2) - 1
 * at a thickness x along the light, 0.4% at 0.3 and 4% at 1, while the faces' average
 * differentiates the light grid's interpolated depths and blurs the source by a voxel, which
 * measured worse on the calibration's thinner media below 0.3 (docs/design.md "First
 * collisions"). */
#define COLLISION_THIN 0.3
#define COLLISION_THICK 1.0

/* Coordinates packed 21 bits an axis relative to the output voxels' low corner. */
#define FACES_AXIS_BITS 21
#define FACES_EMPTY UINT64_MAX

static uint64_t pack(const int32_t c[3], const int32_t lo[3])
{
    return (uint64_t)(uint32_t)(c[0] - lo[0]) |
           (uint64_t)(uint32_t)(c[1] - lo[1]) << FACES_AXIS_BITS |
           (uint64_t)(uint32_t)(c[2] - lo[2]) << (2 * FACES_AXIS_BITS);
}

static size_t slot_of(uint64_t key, size_t mask)
{
    key ^= key >> 33;
    key *= 0xff51afd7ed558ccdULL;
    key ^= key >> 33;
    return (size_t)key & mask;
}

vdbs_status vdbs_voxel_faces_build(const vdbs_volume *volume, vdbs_voxel_faces *faces,
                                   vdbs_error *err)
{
    memset(faces, 0, sizeof *faces);
    const size_t count = volume->coord_count;
    if (count == 0)
        return VDBS_OK;
    int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
    for (size_t n = 0; n < count; ++n)
        for (int a = 0; a < 3; ++a) {
            const int32_t c = volume->coords[3 * n + a];
            lo[a] = c < lo[a] ? c : lo[a];
            hi[a] = c > hi[a] ? c : hi[a];
        }
    for (int a = 0; a < 3; ++a)
        if ((int64_t)hi[a] - lo[a] + 2 >= (int64_t)1 << FACES_AXIS_BITS)
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "the output voxels span %lld voxels along an axis, over %d",
                                  (long long)hi[a] - lo[a] + 1, (1 << FACES_AXIS_BITS) - 2);
    if (count > (size_t)INT32_MAX)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%zu output voxels, over %d", count, INT32_MAX);
    /* Keys relative to one voxel below the low corner, so that every neighbour packs. */
    for (int a = 0; a < 3; ++a)
        --lo[a];
    size_t size = 1;
    while (size < 2 * count)
        size <<= 1;
    uint64_t *keys = malloc(sizeof *keys * size);
    int32_t *index = malloc(sizeof *index * size);
    faces->neighbour = malloc(sizeof *faces->neighbour * 6 * count);
    faces->density = malloc(sizeof *faces->density * count);
    faces->density_near = malloc(sizeof *faces->density_near * count);
    if (!keys || !index || !faces->neighbour || !faces->density || !faces->density_near) {
        free(keys);
        free(index);
        vdbs_voxel_faces_free(faces);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the faces of %zu voxels",
                              count);
    }
    memset(keys, 0xff, sizeof *keys * size);
    const size_t mask = size - 1;
    for (size_t n = 0; n < count; ++n) {
        const uint64_t key = pack(volume->coords + 3 * n, lo);
        size_t s = slot_of(key, mask);
        while (keys[s] != FACES_EMPTY)
            s = (s + 1) & mask;
        keys[s] = key;
        index[s] = (int32_t)n;
    }
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < (int64_t)count; ++n)
        for (int f = 0; f < 6; ++f) {
            int32_t c[3] = {volume->coords[3 * n], volume->coords[3 * n + 1],
                            volume->coords[3 * n + 2]};
            c[f / 2] += f % 2 ? 1 : -1;
            const uint64_t key = pack(c, lo);
            size_t s = slot_of(key, mask);
            int32_t found = -1;
            for (; keys[s] != FACES_EMPTY; s = (s + 1) & mask)
                if (keys[s] == key) {
                    found = index[s];
                    break;
                }
            faces->neighbour[6 * n + f] = found;
        }
    free(keys);
    free(index);
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    for (size_t n = 0; n < count; ++n) {
        const int32_t *c = volume->coords + 3 * n;
        faces->density[n] = vs_density_voxel(buf, &acc, vs_coord(c[0], c[1], c[2]));
    }
    /* The largest density over the 3 x 3 x 3 block: a maximum along x, then y, then z. */
    float *pass = malloc(sizeof *pass * count);
    if (!pass) {
        vdbs_voxel_faces_free(faces);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the faces of %zu voxels",
                              count);
    }
    memcpy(faces->density_near, faces->density, sizeof *pass * count);
    for (int a = 0; a < 3; ++a) {
        memcpy(pass, faces->density_near, sizeof *pass * count);
        for (size_t n = 0; n < count; ++n)
            for (int side = 0; side < 2; ++side) {
                const int32_t m = faces->neighbour[6 * n + 2 * a + side];
                if (m >= 0 && pass[m] > faces->density_near[n])
                    faces->density_near[n] = pass[m];
            }
    }
    free(pass);
    faces->count = count;
    return VDBS_OK;
}

void vdbs_voxel_faces_free(vdbs_voxel_faces *faces)
{
    free(faces->neighbour);
    free(faces->density);
    free(faces->density_near);
    memset(faces, 0, sizeof *faces);
}

double vdbs_beam_transmittance(double k, float depth)
{
    return depth >= VS_TAU_LIMIT ? 0.0 : exp(-k * (double)depth);
}

void vdbs_first_collisions(const vdbs_volume *volume, const vdbs_voxel_faces *faces,
                           const vdbs_light_table *lights, int light, const float *depth,
                           double density_scale, const double k[3], double *scratch, double *rate,
                           float *travel)
{
    const double side = volume->mean_voxel_size;
    /* A point light keeps the point rule (its radial grid's depths, differentiated, cost more
     * than the thick voxels gain: docs/design.md). */
    const int point_light =
        light < lights->direct_count && lights->direct[light].type == VDBS_LIGHT_POINT;
    const int64_t count = (int64_t)faces->count;
    /* Per centre the transmittance T, the light's travel in index units per world length and
     * its colour E. */
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        double w[3], dir[3];
        vdbs_volume_voxel_point(volume, (size_t)n, w);
        double *at = scratch + VDBS_COLLISION_SCRATCH * n;
        vdbs_lights_arrival(lights, light, w, at + 6, dir);
        for (int ch = 0; ch < 3; ++ch)
            at[ch] = vdbs_beam_transmittance(k[ch], depth[n]);
        vdbs_volume_index_vector(volume, dir, at + 3);
        for (int a = 0; travel && a < 3; ++a)
            travel[3 * n + a] = (float)dir[a];
    }
    /* E times the fall of T through the cube, -d . grad T integrated: per axis, T on the
     * upstream face minus T on the downstream one, a face's T the geometric mean of the two
     * centres' beside it, weighted by the travel's index component (the face's area over the
     * voxel's volume, projected). For a sun or a sky ordinate every face's flow leaves one voxel
     * and enters the next, so the sum over the voxels is what the beam lost. T alone, with E at
     * the centre, rather than E T: a point light's E falls as 1 / r^2 without anything being
     * absorbed, steeply near the light. Where a neighbour is not an output voxel the medium
     * between is empty, so the face keeps the centre's T. */
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n) {
        const double *at = scratch + VDBS_COLLISION_SCRATCH * n;
        const int32_t *nb = faces->neighbour + 6 * n;
        for (int ch = 0; ch < 3; ++ch) {
            const double sigma = k[ch] * density_scale;
            const double centre = sigma * (double)faces->density[n] * at[6 + ch] * at[ch];
            const double x = sigma * (double)faces->density_near[n] * side;
            const double w =
                point_light
                    ? 0.0
                    : fmin(fmax((x - COLLISION_THIN) / (COLLISION_THICK - COLLISION_THIN), 0.0),
                           1.0);
            double fall = 0.0;
            for (int a = 0; w > 0.0 && a < 3; ++a) {
                const double t = at[3 + a];
                if (t == 0.0)
                    continue;
                const int32_t up = nb[2 * a + (t > 0.0 ? 0 : 1)];
                const int32_t down = nb[2 * a + (t > 0.0 ? 1 : 0)];
                const double *u = scratch + VDBS_COLLISION_SCRATCH * (up >= 0 ? up : n);
                const double *v = scratch + VDBS_COLLISION_SCRATCH * (down >= 0 ? down : n);
                fall += fabs(t) * (sqrt(at[ch] * u[ch]) - sqrt(at[ch] * v[ch]));
            }
            const double in = at[6 + ch] * fall;
            rate[3 * n + ch] = (1.0 - w) * centre + w * (in > 0.0 ? in : 0.0);
        }
    }
}

int64_t vdbs_voxel_faces_bytes(size_t count)
{
    const vdbs_voxel_faces *f = NULL; /* sizeof only: the fields' types, as allocated */
    return (int64_t)count *
           (int64_t)(6 * sizeof *f->neighbour + sizeof *f->density + sizeof *f->density_near);
}

int64_t vdbs_collision_sum_bytes(size_t count, int with_flux)
{
    const vdbs_collision_sum *s = NULL; /* sizeof only */
    size_t per =
        VDBS_COLLISION_SCRATCH * sizeof *s->scratch + 3 * sizeof *s->rate + 3 * sizeof *s->total;
    if (with_flux)
        per += 3 * sizeof *s->travel + 9 * sizeof *s->flux;
    return vdbs_voxel_faces_bytes(count) + (int64_t)(per * count);
}

vdbs_status vdbs_collision_sum_init(vdbs_collision_sum *sum, const vdbs_volume *volume,
                                    const vdbs_light_table *lights, double density_scale,
                                    int with_flux, vdbs_error *err)
{
    memset(sum, 0, sizeof *sum);
    sum->volume = volume;
    sum->density_scale = density_scale;
    sum->lights = lights;
    vdbs_status st = vdbs_voxel_faces_build(volume, &sum->faces, err);
    if (st != VDBS_OK)
        return st;
    const size_t count = volume->coord_count ? volume->coord_count : 1;
    sum->scratch = malloc(sizeof *sum->scratch * VDBS_COLLISION_SCRATCH * count);
    sum->rate = malloc(sizeof *sum->rate * 3 * count);
    sum->total = calloc(3 * count, sizeof *sum->total);
    if (with_flux) {
        sum->travel = malloc(sizeof *sum->travel * 3 * count);
        sum->flux = calloc(9 * count, sizeof *sum->flux);
    }
    if (!sum->scratch || !sum->rate || !sum->total || (with_flux && (!sum->travel || !sum->flux))) {
        vdbs_collision_sum_free(sum);
        return vdbs_error_set(err, VDBS_ERR_NOMEM,
                              "out of memory for the first collisions of %zu voxels", count);
    }
    return VDBS_OK;
}

void vdbs_collision_sum_share(vdbs_collision_sum *sum, int light, const float *depth,
                              const double share[3])
{
    const double beam_k[3] = {1.0, 1.0, 1.0};
    vdbs_first_collisions(sum->volume, &sum->faces, sum->lights, light, depth, sum->density_scale,
                          beam_k, sum->scratch, sum->rate, sum->travel);
    const int64_t count = (int64_t)sum->faces.count;
#pragma omp parallel for schedule(static)
    for (int64_t n = 0; n < count; ++n)
        for (int ch = 0; ch < 3; ++ch) {
            const double r = share[ch] * sum->rate[3 * n + ch];
            sum->total[3 * n + ch] += r;
            for (int a = 0; sum->flux && a < 3; ++a)
                sum->flux[9 * n + 3 * a + ch] += r * (double)sum->travel[3 * n + a];
        }
}

void vdbs_collision_sum_light(void *user, int light, const float *depth)
{
    const double all[3] = {1.0, 1.0, 1.0};
    vdbs_collision_sum_share(user, light, depth, all);
}

void vdbs_collision_sum_free(vdbs_collision_sum *sum)
{
    vdbs_voxel_faces_free(&sum->faces);
    free(sum->scratch);
    free(sum->rate);
    free(sum->travel);
    free(sum->total);
    free(sum->flux);
    memset(sum, 0, sizeof *sum);
}
