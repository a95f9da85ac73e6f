/* OpenEXR environment maps of every layout (docs/envmap.md): files written here (exrwrite.h)
 * in half, float and uint; RGB, RGBA, Y, luminance/chroma and one-layer RGB; scanlines and
 * tiles (one level, mipmapped, ripmapped); every compression; a data window other than the
 * display window. Each is loaded through vdbs_envmap_load and its texels compared with what
 * was written: exactly for the lossless codecs (after rounding to the channel's type), to
 * the measured bound of each lossy one. Unusable maps are refused with VDBS_ERR_INPUT, one
 * line, and no map. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "exrwrite.h"
#include "vdbscatter/envmap.h"

enum { W = 40, H = 20, N = W * H, MAXC = 6 };

/* Distinct smooth values per channel (0.05 .. about 3.3; plane 3 is alpha-like). */
static float pattern(int c, int x, int y)
{
    return (float)(0.05 + (1.0 + 0.3 * c) * (1.0 + sin(0.37 * x + 0.21 * y + 1.3 * c)));
}

/* Integers above the half range (uint channels hold them exactly in a float). */
static float pattern_uint(int c, int x, int y)
{
    return (float)((x * 131 + y * 977 + c * 70001) % 200003);
}

typedef struct planes {
    float v[MAXC][N];
    const float *p[MAXC];
} planes;

static void fill(planes *pl, const char *type, int w, int h)
{
    for (int c = 0; c < MAXC; ++c) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                pl->v[c][y * w + x] =
                    strcmp(type, "uint") == 0 ? pattern_uint(c, x, y) : pattern(c, x, y);
        pl->p[c] = pl->v[c];
    }
}

/* What the file stores for a value. */
static float stored(const char *type, float v)
{
    return strcmp(type, "half") == 0 ? test_exr_half(v) : v;
}

static void write_ok(const char *path, const test_exr_spec *spec, const planes *pl)
{
    const char *msg = test_exr_write(path, spec, pl->p);
    if (msg)
        fail_msg("%s", msg);
}

static void load_ok(const char *path, vdbs_envmap *map)
{
    vdbs_error err;
    if (vdbs_envmap_load(path, 1.0, map, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* Worst |read - stored| / stored over the texels; rgb[c] are the planes giving R, G, B. */
static double worst_error(const vdbs_envmap *map, const char *type, const planes *pl,
                          const int rgb[3])
{
    double worst = 0.0;
    for (int i = 0; i < map->width * map->height; ++i)
        for (int c = 0; c < 3; ++c) {
            double want = stored(type, pl->v[rgb[c]][i]);
            double e = fabs(map->rgb[3 * i + c] - want) / fmax(fabs(want), 1e-30);
            worst = fmax(worst, e);
        }
    return worst;
}

typedef struct layout {
    const char *label, *channels, *type, *compression, *tiles;
    int rgb[3];   /* planes that must come back as R, G, B */
    double bound; /* on the relative error against the stored values */
} layout;

static void check_layout(const layout *l)
{
    planes *pl = malloc(sizeof *pl);
    fill(pl, l->type, W, H);
    test_exr_spec spec = {l->channels,          l->type,     l->compression, l->tiles,
                          {0, 0, W - 1, H - 1}, {0, 0, 0, 0}};
    char name[128];
    snprintf(name, sizeof name, "exrmap_%s_%s_%s_%s.exr", l->type, l->compression,
             l->tiles ? l->tiles : "scan", l->channels);
    for (char *p = name; *p; ++p)
        if (*p == ',')
            *p = '-';
    const char *path = test_tmp_path(name);
    write_ok(path, &spec, pl);
    vdbs_envmap map;
    load_ok(path, &map);
    assert_int_equal(map.width, W);
    assert_int_equal(map.height, H);
    double e = worst_error(&map, l->type, pl, l->rgb);
    print_message("%-34s %-5s %-5s %-4s worst relative error %.3e (bound %.1e)\n", l->label,
                  l->type, l->compression, l->tiles ? l->tiles : "scan", e, l->bound);
    assert_true(e <= l->bound);
    vdbs_envmap_free(&map);
    free(pl);
}

#define RGB012                                                                                     \
    {                                                                                              \
        0, 1, 2                                                                                    \
    }

/* Every channel type and set, scanlines and tiles, exactly (half: as stored). */
static void test_layouts(void **state)
{
    (void)state;
    const layout cases[] = {
        {"half RGBA scanline ZIP", "R,G,B,A", "half", "zip", NULL, RGB012, 0.0},
        {"half RGBA listed A,B,G,R", "A,B,G,R", "half", "zip", NULL, {3, 2, 1}, 0.0},
        {"half RGB", "R,G,B", "half", "zip", NULL, RGB012, 0.0},
        {"float RGB", "R,G,B", "float", "zip", NULL, RGB012, 0.0},
        {"float RGBA", "R,G,B,A", "float", "zip", NULL, RGB012, 0.0},
        {"uint RGB", "R,G,B", "uint", "zip", NULL, RGB012, 0.0},
        {"uint RGBA", "R,G,B,A", "uint", "none", NULL, RGB012, 0.0},
        {"Y only (grey)", "Y", "half", "zip", NULL, {0, 0, 0}, 0.0},
        {"Y only float", "Y", "float", "piz", NULL, {0, 0, 0}, 0.0},
        {"Y with A", "A,Y", "half", "zip", NULL, {1, 1, 1}, 0.0},
        {"one layer diffuse.RGB", "diffuse.R,diffuse.G,diffuse.B", "half", "zip", NULL, RGB012,
         0.0},
        {"one RGB layer among others", "diffuse.R,diffuse.G,diffuse.B,depth.Z", "float", "zip",
         NULL, RGB012, 0.0},
        {"plain RGB beside a layer",
         "spec.R,spec.G,spec.B,R,G,B",
         "half",
         "zip",
         NULL,
         {3, 4, 5},
         0.0},
        {"tiled half RGBA", "R,G,B,A", "half", "zip", "one", RGB012, 0.0},
        {"tiled float RGB", "R,G,B", "float", "piz", "one", RGB012, 0.0},
        {"tiled uint RGB", "R,G,B", "uint", "zip", "one", RGB012, 0.0},
        {"tiled mipmapped half RGBA", "R,G,B,A", "half", "zip", "mip", RGB012, 0.0},
        {"tiled ripmapped half RGB", "R,G,B", "half", "zip", "rip", RGB012, 0.0},
        {"tiled mipmapped Y", "Y", "half", "rle", "mip", {0, 0, 0}, 0.0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i)
        check_layout(&cases[i]);
}

/* Every compression on half RGBA and float RGB scanlines and half RGBA tiles. Lossless
 * codecs read back exactly. The lossy bounds are about twice the worst relative errors
 * measured on this pattern with OpenEXR 3.1.5 (at its darkest texels, 0.05): PXR24 rounds
 * floats to 24 bits (1.5e-5; halves are kept), B44/B44A pack 4x4 blocks of halves (4.9e-2;
 * floats are kept), DWAA/DWAB quantise R, G, B in a DCT at the default level 45 (6.4e-2).
 * Channels read in the wrong order would be off by far more (order 1). */
static void test_compressions(void **state)
{
    (void)state;
    static const struct {
        const char *name;
        double half_bound, float_bound;
    } codecs[] = {
        {"none", 0, 0},       {"rle", 0, 0},        {"zips", 0, 0},  {"zip", 0, 0},
        {"piz", 0, 0},        {"pxr24", 0, 3.1e-5}, {"b44", 0.1, 0}, {"b44a", 0.1, 0},
        {"dwaa", 0.13, 0.13}, {"dwab", 0.13, 0.13},
    };
    for (size_t k = 0; k < sizeof codecs / sizeof codecs[0]; ++k) {
        layout a = {"half RGBA scanline", "R,G,B,A", "half", codecs[k].name, NULL, RGB012,
                    codecs[k].half_bound};
        layout b = {"float RGB scanline", "R,G,B", "float", codecs[k].name, NULL, RGB012,
                    codecs[k].float_bound};
        layout c = {"half RGBA tiled",   "R,G,B,A", "half", codecs[k].name, "one", RGB012,
                    codecs[k].half_bound};
        check_layout(&a);
        check_layout(&b);
        check_layout(&c);
    }
}

/* Luminance/chroma (Y, RY, BY, chroma at half resolution) of a constant colour comes back as
 * that colour to the luminance/chroma round trip's precision. */
static void test_luminance_chroma(void **state)
{
    (void)state;
    planes *pl = malloc(sizeof *pl);
    const float colour[3] = {0.8f, 0.5f, 0.25f};
    for (int c = 0; c < 3; ++c) {
        for (int i = 0; i < N; ++i)
            pl->v[c][i] = colour[c];
        pl->p[c] = pl->v[c];
    }
    test_exr_spec spec = {"YC", "half", "piz", NULL, {0, 0, W - 1, H - 1}, {0, 0, 0, 0}};
    const char *path = test_tmp_path("exrmap_yc.exr");
    write_ok(path, &spec, pl);
    vdbs_envmap map;
    load_ok(path, &map);
    double worst = 0.0;
    for (int i = 0; i < N; ++i)
        for (int c = 0; c < 3; ++c)
            worst = fmax(worst, fabs(map.rgb[3 * i + c] - colour[c]) / colour[c]);
    print_message("luminance/chroma constant colour: worst relative error %.3e\n", worst);
    assert_true(worst < 1e-2);
    vdbs_envmap_free(&map);
    free(pl);
}

/* The map is the data window's pixels, wherever the display window is. */
static void test_windows(void **state)
{
    (void)state;
    static const struct {
        int data[4], display[4];
    } cases[] = {
        {{5, 3, 5 + W - 1, 3 + H - 1}, {0, 0, 63, 31}},     /* inside a larger display */
        {{-8, -4, -8 + W - 1, -4 + H - 1}, {0, 0, 23, 11}}, /* overscan, negative origin */
        {{100, 50, 100 + W - 1, 50 + H - 1}, {0, 0, 9, 4}}, /* disjoint */
    };
    planes *pl = malloc(sizeof *pl);
    fill(pl, "float", W, H);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i)
        for (int tiled = 0; tiled < 2; ++tiled) {
            test_exr_spec spec = {"R,G,B,A", "half", "zip", tiled ? "one" : NULL, {0}, {0}};
            memcpy(spec.data_window, cases[i].data, sizeof spec.data_window);
            memcpy(spec.display_window, cases[i].display, sizeof spec.display_window);
            const char *path = test_tmp_path("exrmap_window.exr");
            write_ok(path, &spec, pl);
            vdbs_envmap map;
            load_ok(path, &map);
            assert_int_equal(map.width, W);
            assert_int_equal(map.height, H);
            assert_true(worst_error(&map, "half", pl, (int[3])RGB012) == 0.0);
            vdbs_envmap_free(&map);
        }
    free(pl);
}

static void refused(const char *path, const char *needle)
{
    vdbs_envmap map;
    vdbs_error err;
    assert_int_equal(vdbs_envmap_load(path, 1.0, &map, &err), VDBS_ERR_INPUT);
    print_message("refused: %s\n", err.message);
    if (!strstr(err.message, needle))
        fail_msg("'%s' lacks '%s'", err.message, needle);
    assert_null(strchr(err.message, '\n'));
    assert_null(map.rgb);
    assert_null(map.data);
}

/* Writes a map of `channels` whose plane `c` texel (x, y) is `value`. */
static const char *write_bad(const char *name, const char *channels, const char *type, int w, int h,
                             int c, int x, int y, float value)
{
    planes *pl = malloc(sizeof *pl);
    fill(pl, type, w, h);
    if (c >= 0)
        pl->v[c][y * w + x] = value;
    test_exr_spec spec = {channels, type, "zip", NULL, {0, 0, w - 1, h - 1}, {0, 0, 0, 0}};
    const char *path = test_tmp_path(name);
    write_ok(path, &spec, pl);
    free(pl);
    return path;
}

static void test_refused(void **state)
{
    (void)state;
    refused(write_bad("exrmap_nan.exr", "R,G,B,A", "half", W, H, 1, 7, 3, NAN), "not finite");
    refused(write_bad("exrmap_inf.exr", "R,G,B", "float", W, H, 2, 0, 0, INFINITY), "not finite");
    refused(write_bad("exrmap_neg.exr", "R,G,B,A", "half", W, H, 0, 39, 19, -0.5f), "negative");
    refused(write_bad("exrmap_negy.exr", "Y", "half", W, H, 0, 3, 3, -1.0f), "negative");
    refused(write_bad("exrmap_square.exr", "R,G,B,A", "half", 20, 20, -1, 0, 0, 0.0f),
            "twice as wide");
    refused(write_bad("exrmap_alpha.exr", "A", "half", W, H, -1, 0, 0, 0.0f),
            "no R, G, B or Y channels (channels: A)");
    refused(write_bad("exrmap_rg.exr", "R,G", "half", W, H, -1, 0, 0, 0.0f),
            "no R, G, B or Y channels (channels: G, R)");
    refused(write_bad("exrmap_layers.exr",
                      "diffuse.R,diffuse.G,diffuse.B,specular.R,specular.G,specular.B", "half", W,
                      H, -1, 0, 0, 0.0f),
            "several layers with R, G, B and no plain R, G, B (channels: diffuse.B");

    /* A display window 2:1 around a data window that is not. */
    planes *pl = malloc(sizeof *pl);
    fill(pl, "half", W, H);
    test_exr_spec spec = {"R,G,B", "half", "zip", NULL, {0, 0, 29, 19}, {0, 0, 39, 19}};
    const char *crop = test_tmp_path("exrmap_crop.exr");
    write_ok(crop, &spec, pl);
    refused(crop, "twice as wide");

    /* Truncated: the pixels cut short, the header cut short. */
    test_exr_spec whole = {"R,G,B,A", "half", "none", NULL, {0, 0, W - 1, H - 1}, {0}};
    const char *full = test_tmp_path("exrmap_full.exr");
    write_ok(full, &whole, pl);
    const char *cut = test_tmp_path("exrmap_cut.exr");
    test_truncated_copy(full, cut, 0.6);
    refused(cut, "exrmap_cut.exr");
    test_truncated_copy(full, cut, 0.02);
    refused(cut, "exrmap_cut.exr");
    test_exr_spec tiled = {"R,G,B,A", "half", "zip", "one", {0, 0, W - 1, H - 1}, {0}};
    write_ok(full, &tiled, pl);
    test_truncated_copy(full, cut, 0.7);
    refused(cut, "exrmap_cut.exr");
    free(pl);

    /* Not an OpenEXR file; the magic number and then nonsense. */
    const char *text = test_tmp_path("exrmap_text.exr");
    FILE *f = fopen(text, "wb");
    fputs("this is not an image\n", f);
    fclose(f);
    refused(text, "not an OpenEXR or Radiance HDR");
    f = fopen(text, "wb");
    const unsigned char magic[] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    fwrite(magic, 1, sizeof magic, f);
    fputs("garbage garbage garbage garbage garbage garbage", f);
    fclose(f);
    refused(text, "exrmap_text.exr");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layouts),          cmocka_unit_test(test_compressions),
        cmocka_unit_test(test_luminance_chroma), cmocka_unit_test(test_windows),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
