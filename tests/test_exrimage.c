/* Images read through vdbs_image_read from OpenEXR files other tools write (exrwrite.h):
 * half RGBA ZIP (the layout most tools write, which crashed OpenEXRCore 3.1.5), float RGB,
 * half RGB with the se.R, se.G, se.B channels of `render --mode reference`, tiled and
 * mipmapped, DWAA and DWAB, Y alone, a data window off the origin. Values are checked exactly
 * for float, after rounding to half for half channels, and to a measured bound for the DWA
 * codecs (whose se channels stay lossless). A truncated file and one without R, G, B or Y are
 * refused with VDBS_ERR_INPUT, one line naming the file, and no image. */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "exrwrite.h"
#include "vdbscatter/image.h"

enum { W = 37, H = 23, N = W * H, MAXC = 7 };

/* Smooth distinct values per channel: 0.05 .. about 4 for colour, 1e-3 .. 0.05 for se. */
static float pattern(int c, int x, int y)
{
    double v = 0.05 + (1.0 + 0.3 * c) * (1.0 + sin(0.37 * x + 0.21 * y + 1.3 * c));
    return (float)(c >= 4 ? 1e-3 + 0.012 * v : v);
}

typedef struct planes {
    float v[MAXC][N];
    const float *p[MAXC];
} planes;

/* Planes for a comma-separated channel list: R, G, B are patterns 0..2, A is 3, se.R,
 * se.G, se.B are 4..6, Y is 0 and anything else is pattern 3. */
static int pattern_of(const char *name)
{
    static const char *const known[] = {"R", "G", "B", "A", "se.R", "se.G", "se.B", "Y"};
    for (int k = 0; k < 8; ++k)
        if (strcmp(name, known[k]) == 0)
            return k == 7 ? 0 : k;
    return 3;
}

static void fill(planes *pl, const char *channels, int w, int h)
{
    char list[128];
    snprintf(list, sizeof list, "%s", channels);
    int c = 0;
    for (char *save = NULL, *name = strtok_r(list, ",", &save); name && c < MAXC;
         name = strtok_r(NULL, ",", &save), ++c) {
        const int k = pattern_of(name);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                pl->v[c][y * w + x] = pattern(k, x, y);
        pl->p[c] = pl->v[c];
    }
}

static const char *write_file(const char *name, const test_exr_spec *spec, planes *pl)
{
    const int w = spec->data_window[2] - spec->data_window[0] + 1;
    const int h = spec->data_window[3] - spec->data_window[1] + 1;
    fill(pl, spec->channels, w, h);
    const char *path = test_tmp_path(name);
    const char *msg = test_exr_write(path, spec, pl->p);
    if (msg)
        fail_msg("%s", msg);
    return path;
}

static float stored(const char *type, float v)
{
    return strcmp(type, "half") == 0 ? test_exr_half(v) : v;
}

/* Worst relative error of rgb (from patterns 0..2, or 0 for grey) and of se (patterns 4..6)
 * against the stored values; se_error < 0 when the image has no se. */
static void worst_errors(const vdbs_image *im, const char *type, int grey, double *rgb_error,
                         double *se_error)
{
    *rgb_error = 0.0;
    *se_error = im->se ? 0.0 : -1.0;
    for (int y = 0; y < im->height; ++y)
        for (int x = 0; x < im->width; ++x)
            for (int c = 0; c < 3; ++c) {
                const size_t i = 3 * ((size_t)y * im->width + x) + c;
                double want = stored(type, pattern(grey ? 0 : c, x, y));
                *rgb_error = fmax(*rgb_error, fabs(im->rgb[i] - want) / want);
                if (im->se) {
                    want = stored(type, pattern(4 + c, x, y));
                    *se_error = fmax(*se_error, fabs(im->se[i] - want) / want);
                }
            }
}

typedef struct layout {
    const char *label;
    const char *channels, *type, *compression, *tiles;
    int off_origin; /* data window (-5, 3) .. inside a display window (0, 0) .. (63, 31) */
    int with_se, grey;
    double bound, se_bound; /* on the relative errors of R, G, B and of se.R, se.G, se.B */
} layout;

static void test_layouts(void **state)
{
    (void)state;
    /* DWA bounds: about twice the worst relative errors measured on these smooth patterns:
     * 0.064 on colour (down to 0.05) and 0.33 on se (down to 1e-3), which DWA compresses
     * lossily too (it classifies a channel by its name after the last dot). */
    const layout layouts[] = {
        {"half RGBA zip", "R,G,B,A", "half", "zip", NULL, 0, 0, 0, 0, 0},
        {"float RGB zip", "R,G,B", "float", "zip", NULL, 0, 0, 0, 0, 0},
        {"float RGB none", "R,G,B", "float", "none", NULL, 0, 0, 0, 0, 0},
        {"half RGB + se zip", "R,G,B,se.R,se.G,se.B", "half", "zip", NULL, 0, 1, 0, 0, 0},
        {"half RGBA + se piz", "se.B,A,B,se.R,G,R,se.G", "half", "piz", NULL, 0, 1, 0, 0, 0},
        {"float RGB + se tiled", "R,G,B,se.R,se.G,se.B", "float", "zip", "one", 0, 1, 0, 0, 0},
        {"half RGBA mipmapped", "R,G,B,A", "half", "zips", "mip", 0, 0, 0, 0, 0},
        {"half RGBA off-origin window", "R,G,B,A", "half", "zip", NULL, 1, 0, 0, 0, 0},
        {"half Y zip", "Y", "half", "zip", NULL, 0, 0, 1, 0, 0},
        {"half RGBA dwaa", "R,G,B,A", "half", "dwaa", NULL, 0, 0, 0, 0.13, 0},
        {"half RGB + se dwaa", "R,G,B,se.R,se.G,se.B", "half", "dwaa", NULL, 0, 1, 0, 0.13, 0.7},
        {"float RGB dwab", "R,G,B", "float", "dwab", NULL, 0, 0, 0, 0.13, 0},
    };
    planes *pl = malloc(sizeof *pl);
    assert_non_null(pl);
    for (size_t k = 0; k < sizeof layouts / sizeof layouts[0]; ++k) {
        const layout *l = &layouts[k];
        test_exr_spec spec = {l->channels,          l->type, l->compression, l->tiles,
                              {0, 0, W - 1, H - 1}, {0}};
        if (l->off_origin) {
            const int dw[4] = {-5, 3, W - 6, H + 2}, disp[4] = {0, 0, 63, 31};
            memcpy(spec.data_window, dw, sizeof dw);
            memcpy(spec.display_window, disp, sizeof disp);
        }
        const char *path = write_file("test_exrimage.exr", &spec, pl);
        vdbs_image im;
        vdbs_error err;
        if (vdbs_image_read(path, &im, &err) != VDBS_OK)
            fail_msg("%s: %s", l->label, err.message);
        assert_int_equal(im.width, W);
        assert_int_equal(im.height, H);
        assert_int_equal(im.se != NULL, l->with_se);
        double e_rgb, e_se;
        worst_errors(&im, l->type, l->grey, &e_rgb, &e_se);
        print_message("%-28s worst relative error rgb %.3e se %.3e (bounds %.2g, %.2g)\n", l->label,
                      e_rgb, e_se, l->bound, l->se_bound);
        assert_true(e_rgb <= l->bound);
        assert_true(e_se <= l->se_bound); /* e_se is -1 without se */
        if (l->grey)
            for (size_t i = 0; i < (size_t)N; ++i)
                assert_true(im.rgb[3 * i] == im.rgb[3 * i + 1] &&
                            im.rgb[3 * i] == im.rgb[3 * i + 2]);
        vdbs_image_free(&im);
        unlink(path);
    }
    free(pl);
}

/* An EXR written by vdbs_image_write reads back bit for bit with its se channels, and the
 * half copy of the same image compares to it within half rounding. */
static void test_own_files_and_half_copy(void **state)
{
    (void)state;
    vdbs_image im, back, half_back;
    vdbs_error err;
    assert_int_equal(vdbs_image_alloc(&im, W, H, 1, &err), VDBS_OK);
    planes *pl = malloc(sizeof *pl);
    assert_non_null(pl);
    for (int c = 0; c < 6; ++c) {
        pl->p[c] = pl->v[c];
        for (int i = 0; i < N; ++i) {
            float v = pattern(c < 3 ? c : c + 1, i % W, i / W);
            pl->v[c][i] = v;
            (c < 3 ? im.rgb : im.se)[3 * i + c % 3] = v;
        }
    }
    const char *own = test_tmp_path("test_exrimage_own.exr");
    assert_int_equal(vdbs_image_write(own, &im, 0.0, &err), VDBS_OK);
    if (vdbs_image_read(own, &back, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_non_null(back.se);
    assert_memory_equal(back.rgb, im.rgb, sizeof(float) * 3 * N);
    assert_memory_equal(back.se, im.se, sizeof(float) * 3 * N);

    test_exr_spec spec = {"R,G,B,se.R,se.G,se.B", "half", "zip", NULL, {0, 0, W - 1, H - 1}, {0}};
    const char *half = test_tmp_path("test_exrimage_half.exr");
    const char *msg = test_exr_write(half, &spec, pl->p);
    if (msg)
        fail_msg("%s", msg);
    if (vdbs_image_read(half, &half_back, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_image_metrics m;
    assert_int_equal(vdbs_image_compare(&half_back, &back, 0.0, &m, &err), VDBS_OK);
    print_message("half copy against float: relrmse %.3e\n", m.relrmse);
    assert_true(m.relrmse > 0.0 && m.relrmse < 1e-3);
    vdbs_image_free(&im);
    vdbs_image_free(&back);
    vdbs_image_free(&half_back);
    free(pl);
    unlink(own);
    unlink(half);
}

static void refused(const char *path, const char *needle)
{
    vdbs_image im;
    vdbs_error err;
    memset(&im, 0x5a, sizeof im);
    assert_int_equal(vdbs_image_read(path, &im, &err), VDBS_ERR_INPUT);
    print_message("refused: %s\n", err.message);
    assert_non_null(strstr(err.message, path));
    assert_non_null(strstr(err.message, needle));
    assert_null(strchr(err.message, '\n'));
    assert_null(im.rgb);
    assert_null(im.se);
}

static void test_refused(void **state)
{
    (void)state;
    planes *pl = malloc(sizeof *pl);
    assert_non_null(pl);
    const char *cut = test_tmp_path("test_exrimage_cut.exr");
    test_exr_spec scan = {"R,G,B,A", "half", "zip", NULL, {0, 0, W - 1, H - 1}, {0}};
    const char *full = write_file("test_exrimage_full.exr", &scan, pl);
    test_truncated_copy(full, cut, 0.6);
    refused(cut, "test_exrimage_cut.exr");
    test_truncated_copy(full, cut, 0.02); /* inside the header */
    refused(cut, "test_exrimage_cut.exr");
    test_exr_spec tiled = {"R,G,B,se.R,se.G,se.B", "float", "none", "one",
                           {0, 0, W - 1, H - 1},   {0}};
    write_file("test_exrimage_full.exr", &tiled, pl);
    test_truncated_copy(full, cut, 0.7);
    refused(cut, "test_exrimage_cut.exr");

    test_exr_spec no_rgb = {"Z,A", "half", "zip", NULL, {0, 0, W - 1, H - 1}, {0}};
    refused(write_file("test_exrimage_z.exr", &no_rgb, pl), "no R, G, B or Y channels");
    test_exr_spec rg = {"R,G,se.R,se.G,se.B", "float", "zip", NULL, {0, 0, W - 1, H - 1}, {0}};
    refused(write_file("test_exrimage_rg.exr", &rg, pl), "(channels: G, R, se.B, se.G, se.R)");
    free(pl);
    unlink(full);
    unlink(cut);
    unlink(test_tmp_path("test_exrimage_z.exr"));
    unlink(test_tmp_path("test_exrimage_rg.exr"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layouts),
        cmocka_unit_test(test_own_files_and_half_copy),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
