#include "vdbscatter/radial.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vdbs_math.h"
#include "vdbscatter/volume.h"

/* Sub-texels per axis that integrate a texel's solid angle. */
#define RADIAL_OMEGA_SUBDIVISION 16

/* The unnormalised direction at map coordinates (u, v) in [-1, 1]^2: the octahedron
 * |x| + |y| + |z| = 1, its lower half folded over the diamond's edges, or the image plane. */
static void map_point(const vdbs_radial_frame *f, double u, double v, double p[3])
{
    if (f->map == VDBS_RADIAL_OCTAHEDRAL) {
        double z = 1.0 - fabs(u) - fabs(v);
        if (z < 0.0) {
            double fu = (1.0 - fabs(v)) * (u >= 0.0 ? 1.0 : -1.0);
            double fv = (1.0 - fabs(u)) * (v >= 0.0 ? 1.0 : -1.0);
            u = fu;
            v = fv;
        }
        p[0] = u;
        p[1] = v;
        p[2] = z;
        return;
    }
    double x = u * f->tan_half[0], y = v * f->tan_half[1];
    for (int a = 0; a < 3; ++a)
        p[a] = f->forward[a] + x * f->right[a] + y * f->up[a];
}

double vdbs_radial_direction(const vdbs_radial_frame *f, double x, double y, double dir[3])
{
    double u = 2.0 * x / f->n[0] - 1.0, v = 2.0 * y / f->n[1] - 1.0, p[3];
    map_point(f, u, v, p);
    double len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    for (int a = 0; a < 3; ++a)
        dir[a] = p[a] / len;
    /* dOmega = du dv / |p|^3 on both maps (the octahedron's face normal (+-1, +-1, +-1) has
     * p . n = 1; the fold is an isometry of the square), times the texel's du/dx dv/dy. */
    double jac = (2.0 / f->n[0]) * (2.0 / f->n[1]);
    if (f->map == VDBS_RADIAL_PERSPECTIVE)
        jac *= f->tan_half[0] * f->tan_half[1];
    return jac / (len * len * len);
}

/* Texel solid angles and centre directions. */
static void texel_tables(vdbs_radial_frame *f)
{
    const int m = RADIAL_OMEGA_SUBDIVISION;
    double total = 0.0;
    for (int j = 0; j < f->n[1]; ++j)
        for (int i = 0; i < f->n[0]; ++i) {
            int t = j * f->n[0] + i;
            double omega = 0.0, d[3];
            for (int b = 0; b < m; ++b)
                for (int a = 0; a < m; ++a)
                    omega +=
                        vdbs_radial_direction(f, i + (a + 0.5) / m, j + (b + 0.5) / m, d) / (m * m);
            vdbs_radial_direction(f, i + 0.5, j + 0.5, f->dir + 3 * t);
            f->omega[t] = omega;
            total += omega;
        }
    if (f->map == VDBS_RADIAL_OCTAHEDRAL)
        for (int t = 0; t < f->n[0] * f->n[1]; ++t)
            f->omega[t] *= 4.0 * VDBS_PI / total;
}

static vdbs_status frame_alloc(vdbs_radial_frame *f, int texels, int shells, vdbs_error *err)
{
    f->n[0] = f->n[1] = texels;
    f->n[2] = shells;
    f->radius = malloc(sizeof *f->radius * (size_t)(shells + 1));
    f->omega = malloc(sizeof *f->omega * (size_t)texels * texels);
    f->dir = malloc(sizeof *f->dir * 3 * (size_t)texels * texels);
    if (!f->radius || !f->omega || !f->dir) {
        vdbs_radial_free(f);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a radial grid");
    }
    return VDBS_OK;
}

vdbs_status vdbs_radial_octahedral(const double centre[3], int texels, int shells, double r_inner,
                                   double r_outer, vdbs_radial_frame *f, vdbs_error *err)
{
    memset(f, 0, sizeof *f);
    if (texels < 2 || texels % 2 != 0 || shells < 1 || !(r_inner >= 0.0) || !(r_outer > r_inner))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "radial grid: %d texels (even, >= 2), %d shells, radii %g to %g",
                              texels, shells, r_inner, r_outer);
    f->map = VDBS_RADIAL_OCTAHEDRAL;
    memcpy(f->centre, centre, sizeof f->centre);
    vdbs_status st = frame_alloc(f, texels, shells, err);
    if (st != VDBS_OK)
        return st;
    /* Cells about as long as wide: shells r_k = r_1 q^(k - 1) with q = 1 + the texel's
     * angular width sqrt(4 pi) / n, reaching r_outer; where that would start inside r_inner
     * (the light is far from the medium) the shells start at r_inner instead, thinner. */
    double q = 1.0 + sqrt(4.0 * VDBS_PI) / texels;
    double r1 = fmax(r_inner, r_outer * pow(q, -(double)(shells - 1)));
    if (!(r1 > 0.0) || r1 >= r_outer)
        r1 = shells > 1 ? r_outer * pow(q, -(double)(shells - 1)) : r_outer;
    double ratio = shells > 1 ? pow(r_outer / r1, 1.0 / (shells - 1)) : 1.0;
    f->radius[0] = 0.0;
    for (int k = 1; k <= shells; ++k)
        f->radius[k] = r1 * pow(ratio, k - 1);
    f->radius[shells] = r_outer;
    texel_tables(f);
    return VDBS_OK;
}

vdbs_status vdbs_radial_perspective(const vdbs_camera_frame *camera, int texels, int shells,
                                    double r_near, double r_far, vdbs_radial_frame *f,
                                    vdbs_error *err)
{
    memset(f, 0, sizeof *f);
    if (texels < 1 || shells < 1 || !(r_near > 0.0) || !(r_far > r_near))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "frustum grid: %d texels, %d shells, radii %g to %g", texels, shells,
                              r_near, r_far);
    f->map = VDBS_RADIAL_PERSPECTIVE;
    memcpy(f->centre, camera->origin, sizeof f->centre);
    memcpy(f->forward, camera->forward, sizeof f->forward);
    memcpy(f->right, camera->right, sizeof f->right);
    memcpy(f->up, camera->up, sizeof f->up);
    f->tan_half[0] = camera->tan_half_x;
    f->tan_half[1] = camera->tan_half_y;
    vdbs_status st = frame_alloc(f, texels, shells, err);
    if (st != VDBS_OK)
        return st;
    /* Perspective-warped: the depth of a cell grows with its distance, as its width does. */
    for (int k = 0; k <= shells; ++k)
        f->radius[k] = r_near * pow(r_far / r_near, (double)k / shells);
    texel_tables(f);
    return VDBS_OK;
}

void vdbs_radial_free(vdbs_radial_frame *f)
{
    free(f->radius);
    free(f->omega);
    free(f->dir);
    f->radius = f->omega = f->dir = NULL;
}

int64_t vdbs_radial_cells(const vdbs_radial_frame *f)
{
    return (int64_t)f->n[0] * f->n[1] * f->n[2];
}

double vdbs_radial_cell_volume(const vdbs_radial_frame *f, int64_t cell)
{
    int64_t texels = (int64_t)f->n[0] * f->n[1];
    int k = (int)(cell / texels);
    double r0 = f->radius[k], r1 = f->radius[k + 1];
    return f->omega[cell % texels] * (r1 * r1 * r1 - r0 * r0 * r0) / 3.0;
}

double vdbs_radial_cell_area(const vdbs_radial_frame *f, int64_t cell)
{
    int64_t texels = (int64_t)f->n[0] * f->n[1];
    int k = (int)(cell / texels);
    double r0 = f->radius[k], r1 = f->radius[k + 1];
    return f->omega[cell % texels] * (r1 * r1 + r1 * r0 + r0 * r0) / 3.0;
}

/* The centroid radius of the shell between ra and rb: 3/4 (rb^4 - ra^4) / (rb^3 - ra^3), without
 * the differences (the kernel's vs_pop_radial_centre, in double). */
static double shell_centroid(double ra, double rb)
{
    return 0.75 * (rb + ra) * (rb * rb + ra * ra) / (rb * rb + rb * ra + ra * ra);
}

void vdbs_radial_cell_centroid(const vdbs_radial_frame *f, int64_t cell, double world[3])
{
    int64_t texels = (int64_t)f->n[0] * f->n[1];
    int k = (int)(cell / texels);
    const double r = shell_centroid(f->radius[k], f->radius[k + 1]);
    const double *d = f->dir + 3 * (cell % texels);
    for (int a = 0; a < 3; ++a)
        world[a] = f->centre[a] + r * d[a];
}

int vdbs_radial_cell_parts(const vdbs_radial_frame *f, int64_t cell, double side, double *world,
                           double *volume)
{
    int64_t texels = (int64_t)f->n[0] * f->n[1];
    int t = (int)(cell % texels), k = (int)(cell / texels);
    int i = t % f->n[0], j = t / f->n[0];
    double r0 = f->radius[k], r1 = f->radius[k + 1];
    double width = fmax(r1 - r0, r1 * sqrt(f->omega[t]));
    int m = side > 0.0 ? (int)ceil(width / side - 1e-9) : 1;
    m = m < 1 ? 1 : (m > VDBS_RADIAL_MAX_SPLIT ? VDBS_RADIAL_MAX_SPLIT : m);
    double total = 0.0;
    int p = 0;
    for (int c = 0; c < m; ++c) {
        double ra = r0 + (r1 - r0) * c / m, rb = r0 + (r1 - r0) * (c + 1) / m;
        double shell = (rb * rb * rb - ra * ra * ra) / 3.0;
        double centroid = shell_centroid(ra, rb);
        for (int b = 0; b < m; ++b)
            for (int a = 0; a < m; ++a, ++p) {
                double d[3];
                double omega =
                    vdbs_radial_direction(f, i + (a + 0.5) / m, j + (b + 0.5) / m, d) / (m * m);
                for (int x = 0; x < 3; ++x)
                    world[3 * p + x] = f->centre[x] + centroid * d[x];
                volume[p] = omega * shell;
                total += volume[p];
            }
    }
    double want = vdbs_radial_cell_volume(f, cell);
    for (int q = 0; q < p && total > 0.0; ++q)
        volume[q] *= want / total;
    return p;
}

void vdbs_radial_sigma(const vdbs_radial_frame *f, const vdbs_volume *volume,
                       const vdbs_medium_box *box, double density_scale, double side, float *sigma)
{
    const int64_t cells = vdbs_radial_cells(f);
#pragma omp parallel for schedule(dynamic, 64)
    for (int64_t c = 0; c < cells; ++c) {
        double w[3 * VDBS_RADIAL_MAX_PARTS], v[VDBS_RADIAL_MAX_PARTS], sum = 0.0, vol = 0.0;
        int parts = vdbs_radial_cell_parts(f, c, side, w, v), inside = 0;
        for (int p = 0; p < parts; ++p) {
            double idx[3];
            vdbs_volume_index_point(volume, w + 3 * p, idx);
            sum += v[p] * vdbs_medium_box_density(box, idx);
            vol += v[p];
            inside |= vdbs_volume_in_support(volume, w + 3 * p);
        }
        sigma[c] =
            inside ? (float)(density_scale * (vol > 0.0 ? sum / vol : 0.0)) : VDBS_RADIAL_OUTSIDE;
    }
}
