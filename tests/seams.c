#include "seams.h"
#include "seams_bake.h"

#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/bake.h"
#include "vdbscatter/fld.h"
#include "vdbscatter/pop.h"
#include "vdbscatter/svd.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_march.h"

#define SEAM_PI 3.14159265358979323846
/* Runs shorter than this many voxels, or than this many cells, are left out: too few bins
 * between the detrended mean and the cell frequency. */
#define SEAM_MIN_RUN 16
#define SEAM_MIN_CELLS 4.0
/* Neighbouring frequencies: f0 + k / SHORTEST for these k, SHORTEST the shortest run
 * admitted, so that they lie outside every run's Hann main lobe (+-2 bins of the run). */
#define SEAM_NEIGHBOURS 4
static const double seam_offsets[SEAM_NEIGHBOURS] = {-3.0, -2.0, 2.0, 3.0};

/* Adds one run's contribution to the complex spectra `sum` (re, im per frequency) of |d2|:
 * detrended (its least-squares line removed, so that its mean does not leak into the bins),
 * Hann-windowed, at the absolute voxel positions start + i, so that cell planes, which sit at
 * the same positions on every line, add in phase over the runs while detail does not. |d2|,
 * not d2: a C0 reconstruction's kinks sit on the cell planes whatever their sign and size. */
static void run_spectrum(double *d2, int len, int start, int nf, const double *freq, double *sum)
{
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    for (int i = 0; i < len; ++i) {
        d2[i] = fabs(d2[i]);
        sx += i;
        sy += d2[i];
        sxx += (double)i * i;
        sxy += i * d2[i];
    }
    const double slope = (len * sxy - sx * sy) / (len * sxx - sx * sx);
    const double icept = (sy - slope * sx) / len;
    for (int i = 0; i < len; ++i) {
        const double w = 0.5 - 0.5 * cos(2.0 * SEAM_PI * (i + 0.5) / len);
        d2[i] = w * (d2[i] - icept - slope * i);
    }
    for (int f = 0; f < nf; ++f)
        for (int i = 0; i < len; ++i) {
            const double phase = 2.0 * SEAM_PI * freq[f] * (start + i);
            sum[2 * f] += d2[i] * cos(phase);
            sum[2 * f + 1] -= d2[i] * sin(phase);
        }
}

void test_seams_dense(const double *m, const unsigned char *inside, const int n[3],
                      const double cell_voxels[3], test_seams *out)
{
    const int64_t stride[3] = {1, n[0], (int64_t)n[0] * n[1]};
    for (int a = 0; a < 3; ++a) {
        out->ratio[a] = 0.0;
        out->cell_voxels[a] = cell_voxels[a];
        out->lines[a] = 0;
        const int len = n[a];
        const int b = (a + 1) % 3, c = (a + 2) % 3;
        const double f0 = 1.0 / cell_voxels[a];
        /* At least SEAM_MIN_RUN voxels and SEAM_MIN_CELLS cells, and long enough that the
         * upper neighbours stay below Nyquist. */
        double shortest = fmax(SEAM_MIN_CELLS / f0, (double)SEAM_MIN_RUN);
        if (f0 < 0.5)
            shortest = fmax(shortest, floor(seam_offsets[SEAM_NEIGHBOURS - 1] / (0.5 - f0)) + 1.0);
        const int min_run = (int)ceil(shortest);
        double freq[1 + SEAM_NEIGHBOURS];
        freq[0] = f0;
        for (int k = 0; k < SEAM_NEIGHBOURS; ++k)
            freq[1 + k] = f0 + seam_offsets[k] / min_run;
        /* The neighbours past DC or Nyquist: cells too small or too large to measure. */
        if (freq[1] <= 0.0 || freq[SEAM_NEIGHBOURS] >= 0.5 || len < min_run + 2)
            continue;
        double *d2 = malloc(sizeof *d2 * (size_t)len);
        assert_true(d2);
        double power[1 + SEAM_NEIGHBOURS] = {0};
        for (int k = 0; k < n[c]; ++k) {
            /* One plane's lines are summed in phase; the planes' powers are averaged, which
             * keeps the ratio's spread on a field without seams small (a single coherent sum
             * is one complex number: its power scatters like chi-square with 2 degrees). */
            double sum[2 * (1 + SEAM_NEIGHBOURS)] = {0};
            for (int j = 0; j < n[b]; ++j) {
                const int64_t base = j * stride[b] + k * stride[c];
                /* Each run of voxels whose d2 lies inside the medium is its own window, so
                 * that the medium's edges do not smear the cell frequency over its
                 * neighbours. */
                int run = 0, used = 0;
                for (int i = 1; i < len; ++i) {
                    const int64_t at = base + i * stride[a];
                    const int in = i < len - 1 && inside[at - stride[a]] && inside[at] &&
                                   inside[at + stride[a]];
                    if (in) {
                        d2[run++] = m[at + stride[a]] - 2.0 * m[at] + m[at - stride[a]];
                        continue;
                    }
                    if (run >= min_run) {
                        run_spectrum(d2, run, i - run, 1 + SEAM_NEIGHBOURS, freq, sum);
                        used = 1;
                    }
                    run = 0;
                }
                out->lines[a] += used;
            }
            for (int f = 0; f <= SEAM_NEIGHBOURS; ++f)
                power[f] += sum[2 * f] * sum[2 * f] + sum[2 * f + 1] * sum[2 * f + 1];
        }
        double nb = 0.0;
        for (int f = 1; f <= SEAM_NEIGHBOURS; ++f)
            nb += power[f] / SEAM_NEIGHBOURS;
        out->ratio[a] = nb > 0.0 ? power[0] / nb : 0.0;
        free(d2);
    }
}

void test_seams_measure(const vdbs_volume *volume, const float *field, double cell_world,
                        test_seams *out)
{
    int lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
    for (size_t v = 0; v < volume->coord_count; ++v)
        for (int a = 0; a < 3; ++a) {
            const int32_t x = volume->coords[3 * v + a];
            lo[a] = x < lo[a] ? x : lo[a];
            hi[a] = x > hi[a] ? x : hi[a];
        }
    int n[3];
    double cell_voxels[3];
    for (int a = 0; a < 3; ++a) {
        n[a] = hi[a] - lo[a] + 1;
        double len = 0.0;
        for (int k = 0; k < 3; ++k)
            len += volume->index_to_world[k][a] * volume->index_to_world[k][a];
        cell_voxels[a] = cell_world / sqrt(len);
    }
    const size_t total = (size_t)n[0] * n[1] * n[2];
    double *m = calloc(total, sizeof *m);
    unsigned char *inside = calloc(total, 1);
    assert_true(m && inside);
    pnanovdb_buf_t buf = pnanovdb_make_buf(volume->nano, volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    for (size_t v = 0; v < volume->coord_count; ++v) {
        const int32_t *co = volume->coords + 3 * v;
        const size_t at = ((size_t)(co[2] - lo[2]) * n[1] + (size_t)(co[1] - lo[1])) * n[0] +
                          (size_t)(co[0] - lo[0]);
        const float *f = field + 3 * v;
        m[at] = 0.2126 * f[0] + 0.7152 * f[1] + 0.0722 * f[2];
        inside[at] = vs_density_voxel(buf, &acc, vs_coord(co[0], co[1], co[2])) > 0.0f;
    }
    test_seams_dense(m, inside, n, cell_voxels, out);
    free(m);
    free(inside);
}

double test_seams_bake(const vdbs_volume *volume, const vdbs_scene *scene, test_seams *ms,
                       test_seams l1[3])
{
    const size_t n = volume->coord_count;
    float *radiance = calloc(3 * n, sizeof(float)), *out = calloc(3 * n, sizeof(float));
    float *moment[3] = {calloc(3 * n, sizeof(float)), calloc(3 * n, sizeof(float)),
                        calloc(3 * n, sizeof(float))};
    assert_true(radiance && out && moment[0] && moment[1] && moment[2]);
    vdbs_bake_options o = {0};
    o.scene = scene;
    o.backend = VDBS_BACKEND_CPU;
    vdbs_bake_report report;
    vdbs_error err;
    if (vdbs_bake_volume(&o, volume, radiance, out, moment, &report, &err) != VDBS_OK)
        fail_msg("%s bake: %s", scene->method, err.message);
    /* The grid each solver upsamples (pop.c's merged grid: half the directional cell, no
     * point lights here; fld.c and svd.c: their world frames of `resolution` cells). */
    const double extent = vdbs_volume_support_extent(volume);
    double cell = 0.0;
    if (strcmp(scene->method, "pop") == 0) {
        const vdbs_pop_stats *p = vdbs_bake_report_stats(&report);
        cell = 0.5 * p->cell_side;
    } else if (strcmp(scene->method, "fld") == 0) {
        const vdbs_fld_stats *f = vdbs_bake_report_stats(&report);
        cell = extent / f->resolution;
    } else if (strcmp(scene->method, "svd") == 0) {
        const vdbs_svd_stats *s = vdbs_bake_report_stats(&report);
        cell = extent / s->resolution;
    } else {
        fail_msg("no coarse grid for method %s", scene->method);
    }
    test_seams_measure(volume, out, cell, ms);
    for (int a = 0; l1 && a < 3; ++a)
        test_seams_measure(volume, moment[a], cell, &l1[a]);
    for (int a = 0; a < 3; ++a)
        free(moment[a]);
    free(radiance);
    free(out);
    return cell;
}
