/* Images: EXR round trips (bit-exact float RGB and se channels), PNG within 8-bit sRGB
 * quantisation, Radiance HDR within RGBE's and cut short anywhere, every read/write error class,
 * and the compare metrics on images with known answers (scaled copies, a known percentile, Gaussian
 * noise of known se). */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "vdbscatter/image.h"

/* Fixed-seed xorshift64* so that the statistical checks are reproducible. */
static uint64_t rng_state = 0x9E3779B97F4A7C15ull;

static double rng_uniform(void)
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 2685821657736338717ull) >> 11) * 0x1.0p-53;
}

static double rng_normal(void)
{
    double u = rng_uniform(), v = rng_uniform();
    return sqrt(-2.0 * log(1.0 - u)) * cos(6.283185307179586 * v);
}

static double srgb_decode(double s)
{
    return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
}

static double srgb_encode(double v)
{
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

static void alloc_ok(vdbs_image *im, int w, int h, int with_se)
{
    vdbs_error err;
    assert_int_equal(vdbs_image_alloc(im, w, h, with_se, &err), VDBS_OK);
}

static void write_ok(const char *path, const vdbs_image *im, double ev)
{
    vdbs_error err;
    vdbs_status st = vdbs_image_write(path, im, ev, &err);
    if (st != VDBS_OK)
        fail_msg("%s", err.message);
}

static void read_ok(const char *path, vdbs_image *im)
{
    vdbs_error err;
    vdbs_status st = vdbs_image_read(path, im, &err);
    if (st != VDBS_OK)
        fail_msg("%s", err.message);
}

static vdbs_image_metrics compare_ok(const vdbs_image *a, const vdbs_image *b, double mask)
{
    vdbs_error err;
    vdbs_image_metrics m;
    vdbs_status st = vdbs_image_compare(a, b, mask, &m, &err);
    if (st != VDBS_OK)
        fail_msg("%s", err.message);
    return m;
}

/* No ".NAME.tmp.*" is left next to NAME in the temp folder. */
static void assert_no_temp(const char *name)
{
    char prefix[256];
    snprintf(prefix, sizeof prefix, ".%s.tmp.", name);
    DIR *d = opendir(test_tmp_path(""));
    assert_non_null(d);
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0)
            fail_msg("temporary file %s left behind", e->d_name);
    closedir(d);
}

/* Writes im to the temp folder's NAME (no temporary file left), reads it back into back, of the
 * same size; returns the path. */
static const char *round_trip(const char *name, const vdbs_image *im, vdbs_image *back)
{
    const char *path = test_tmp_path(name);
    write_ok(path, im, 0.0);
    assert_no_temp(name);
    read_ok(path, back);
    assert_int_equal(back->width, im->width);
    assert_int_equal(back->height, im->height);
    return path;
}

static int file_exists(const char *path)
{
    struct stat s;
    return stat(path, &s) == 0;
}

static void fill_random(vdbs_image *im)
{
    const size_t n = (size_t)im->width * im->height * 3;
    for (size_t i = 0; i < n; ++i) {
        im->rgb[i] = (float)(0.1 + rng_uniform());
        if (im->se)
            im->se[i] = (float)(0.01 + 0.05 * rng_uniform());
    }
}

static void test_exr_round_trip(void **state)
{
    (void)state;
    /* Odd sizes: the last ZIP block holds fewer than 16 lines. */
    vdbs_image im, back;
    alloc_ok(&im, 37, 23, 1);
    const size_t n = (size_t)37 * 23 * 3;
    for (size_t i = 0; i < n; ++i) {
        /* Random bit patterns of finite floats: any change of a bit shows. */
        uint32_t bits;
        do {
            bits = (uint32_t)(rng_uniform() * 4294967296.0);
        } while (((bits >> 23) & 0xff) == 0xff);
        memcpy(&im.rgb[i], &bits, sizeof bits);
        im.se[i] = (float)(rng_uniform() * 1e-3);
    }
    im.rgb[0] = 0.0f;
    im.rgb[1] = -0.0f;
    im.rgb[2] = 1e-40f; /* subnormal */
    im.rgb[3] = 65504.0f * 1000.0f;
    const char *path = test_tmp_path("test_image_rt.exr");
    write_ok(path, &im, 5.0); /* exposure does not touch EXR data */
    assert_no_temp("test_image_rt.exr");
    read_ok(path, &back);
    assert_int_equal(back.width, 37);
    assert_int_equal(back.height, 23);
    assert_non_null(back.se);
    assert_memory_equal(back.rgb, im.rgb, n * sizeof(float));
    assert_memory_equal(back.se, im.se, n * sizeof(float));
    vdbs_image_free(&back);

    /* Without se: no se channels in, none out. */
    free(im.se);
    im.se = NULL;
    write_ok(path, &im, 0.0);
    read_ok(path, &back);
    assert_null(back.se);
    assert_memory_equal(back.rgb, im.rgb, n * sizeof(float));
    vdbs_image_free(&back);
    vdbs_image_free(&im);
    unlink(path);
}

/* OpenEXR 3.1's ZIP encoder kept its zlib output when that was exactly as long as the packed
 * pixels, which readers take for raw pixels: such a chunk read back as garbage. One chunk (16
 * rows of 8 pixels, 1536 bytes) whose first k floats hold random bits and the rest 0.5 compresses
 * to every length from far below the packed size to above it as k grows, over several seeds: every
 * image must read back bit for bit. */
static void test_exr_every_compressed_length(void **state)
{
    (void)state;
    vdbs_image im, back;
    alloc_ok(&im, 8, 16, 0);
    const int n = 8 * 16 * 3;
    const char *path = test_tmp_path("test_image_zip.exr");
    int mismatches = 0;
    for (int seed = 0; seed < 4; ++seed)
        for (int k = 0; k <= n; ++k) {
            for (int i = 0; i < n; ++i) {
                uint32_t bits = 0x3f000000u; /* 0.5 */
                if (i < k)
                    do
                        bits = (uint32_t)(rng_uniform() * 4294967296.0);
                    while (((bits >> 23) & 0xff) == 0xff);
                memcpy(&im.rgb[i], &bits, sizeof bits);
            }
            write_ok(path, &im, 0.0);
            read_ok(path, &back);
            if (memcmp(back.rgb, im.rgb, sizeof(float) * (size_t)n) != 0 && mismatches++ == 0)
                print_message("seed %d, %d random floats: read back differs\n", seed, k);
            vdbs_image_free(&back);
        }
    assert_int_equal(mismatches, 0);
    vdbs_image_free(&im);
    unlink(path);
}

static void test_png_round_trip(void **state)
{
    (void)state;
    vdbs_image im, back;
    alloc_ok(&im, 16, 8, 0);
    const size_t n = (size_t)16 * 8 * 3;
    for (size_t i = 0; i < n; ++i)
        im.rgb[i] = (float)(i / (double)(n - 1));
    const char *path = round_trip("test_image_rt.png", &im, &back);
    assert_null(back.se);
    for (size_t i = 0; i < n; ++i) {
        /* Half a code value in sRGB space, plus float rounding. */
        double e = fabs(srgb_encode(back.rgb[i]) - srgb_encode(im.rgb[i]));
        assert_true(e <= 0.5 / 255.0 + 1e-6);
    }
    vdbs_image_free(&back);

    /* Known code values: linear 0.5 is sRGB 0.7354 -> 188; clamping; NaN is black. */
    const float probe[6] = {0.5f, 2.0f, -1.0f, NAN, 0.0f, 0.25f};
    const int code0[6] = {188, 255, 0, 0, 0, 137};
    for (int ev = 0; ev <= 1; ++ev) {
        for (int i = 0; i < 6; ++i)
            im.rgb[i] = probe[i];
        write_ok(path, &im, ev);
        read_ok(path, &back);
        for (int i = 0; i < 6; ++i) {
            /* Exposure +1 doubles: 0.25 -> 0.5 -> 188, 0.5 -> 1.0 -> 255. */
            int code = ev == 0 ? code0[i] : (i == 5 ? 188 : (i == 0 ? 255 : code0[i]));
            assert_true(back.rgb[i] == (float)srgb_decode(code / 255.0));
        }
        vdbs_image_free(&back);
    }
    vdbs_image_free(&im);
    unlink(path);
}

static void test_read_errors(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_image im;
    const char *missing = test_tmp_path("test_image_missing.exr");
    unlink(missing);
    assert_int_equal(vdbs_image_read(missing, &im, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, missing));
    assert_null(strchr(err.message, '\n'));

    const char *text = test_tmp_path("test_image_text.exr");
    FILE *f = fopen(text, "w");
    assert_non_null(f);
    fputs("this is not an image\n", f);
    fclose(f);
    assert_int_equal(vdbs_image_read(text, &im, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, text));
    unlink(text);

    /* Truncated files of both kinds. */
    vdbs_image src;
    alloc_ok(&src, 64, 64, 1);
    fill_random(&src);
    const char *names[2] = {"test_image_trunc.exr", "test_image_trunc.png"};
    for (int k = 0; k < 2; ++k) {
        const char *path = test_tmp_path(names[k]);
        write_ok(path, &src, 0.0);
        struct stat s;
        assert_int_equal(stat(path, &s), 0);
        assert_int_equal(truncate(path, s.st_size / 2), 0);
        assert_int_equal(vdbs_image_read(path, &im, &err), VDBS_ERR_INPUT);
        assert_non_null(strstr(err.message, path));
        assert_null(strchr(err.message, '\n'));
        assert_null(im.rgb);
        unlink(path);
    }
    vdbs_image_free(&src);
}

/* Radiance HDR: a round trip within RGBE's quantisation (8 mantissa bits shared by the pixel's
 * largest channel, truncated), and every cut of the run-length pixel data refused with one
 * line. stb_image alone loops forever on a scanline cut short (it reads zeros past the end,
 * and a zero count never advances), so each cut is a hang without the reader's own check. */
static void test_hdr_round_trip_and_cuts(void **state)
{
    (void)state;
    vdbs_image src, back;
    vdbs_error err;
    alloc_ok(&src, 64, 16, 0); /* 8 <= width < 32768: stb writes run-length scanlines */
    fill_random(&src);
    const char *path = round_trip("test_image_hdr.hdr", &src, &back);
    for (size_t p = 0; p < (size_t)64 * 16; ++p) {
        const float *a = src.rgb + 3 * p, *b = back.rgb + 3 * p;
        const float top = fmaxf(a[0], fmaxf(a[1], a[2]));
        for (int c = 0; c < 3; ++c)
            assert_true(b[c] <= a[c] && a[c] - b[c] <= top * 0x1p-7f);
    }
    vdbs_image_free(&back);

    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static unsigned char bytes[1 << 16];
    const size_t size = fread(bytes, 1, sizeof bytes, f);
    fclose(f);
    assert_true(size > 0 && size < sizeof bytes);
    const unsigned char *dims = (const unsigned char *)strstr((const char *)bytes, "-Y 16 +X 64\n");
    assert_non_null(dims);
    const size_t data_start = (size_t)(dims - bytes) + strlen("-Y 16 +X 64\n");
    const char *cut = test_tmp_path("test_image_hdr_cut.hdr");
    for (size_t len = data_start; len < size; ++len) {
        f = fopen(cut, "wb");
        assert_non_null(f);
        assert_int_equal(fwrite(bytes, 1, len, f), len);
        fclose(f);
        if (vdbs_image_read(cut, &back, &err) != VDBS_ERR_INPUT)
            fail_msg("an HDR file cut to %zu of %zu bytes was not refused", len, size);
        assert_non_null(strstr(err.message, cut));
        assert_null(strchr(err.message, '\n'));
        assert_null(back.rgb);
    }
    unlink(cut);
    unlink(path);
    vdbs_image_free(&src);
}

static void test_write_errors(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_image im;
    alloc_ok(&im, 4, 4, 0);
    const char *tif = test_tmp_path("test_image_bad.tif");
    assert_int_equal(vdbs_image_write(tif, &im, 0.0, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, tif));
    assert_false(file_exists(tif));
    const char *nodir = test_tmp_path("test_image_no_such_dir/x.exr");
    assert_int_not_equal(vdbs_image_write(nodir, &im, 0.0, &err), VDBS_OK);
    assert_non_null(strstr(err.message, nodir));
    const char *nodir_png = test_tmp_path("test_image_no_such_dir/x.png");
    assert_int_not_equal(vdbs_image_write(nodir_png, &im, 0.0, &err), VDBS_OK);
    vdbs_image_free(&im);
    assert_int_equal(vdbs_image_alloc(&im, 0, 4, 0, &err), VDBS_ERR_INPUT);
    assert_null(im.rgb);
}

static void test_compare_self_and_scaled(void **state)
{
    (void)state;
    vdbs_image a, b;
    alloc_ok(&a, 40, 30, 0);
    alloc_ok(&b, 40, 30, 0);
    fill_random(&b);
    const size_t n = (size_t)40 * 30 * 3;
    memcpy(a.rgb, b.rgb, n * sizeof(float));
    vdbs_image_metrics m = compare_ok(&b, &b, 0.0);
    assert_true(m.relrmse == 0.0 && m.mean_rel == 0.0 && m.p99_rel == 0.0 && m.mean_ratio == 1.0);
    assert_int_equal(m.samples, (long long)n);
    assert_false(m.has_se);

    const double scales[3] = {1.3, 0.7, 1.0001};
    for (int k = 0; k < 3; ++k) {
        const double s = scales[k];
        for (size_t i = 0; i < n; ++i)
            a.rgb[i] = (float)(s * b.rgb[i]);
        m = compare_ok(&a, &b, 0.0);
        assert_true(fabs(m.relrmse - fabs(s - 1.0)) < 1e-6);
        /* rel = |s-1| |b| / (|b| + 1e-3 mean(b)) with b >= 0.1: within 1%. */
        assert_true(m.mean_rel <= fabs(s - 1.0) * (1.0 + 1e-6));
        assert_true(m.mean_rel >= fabs(s - 1.0) * 0.99);
        assert_true(m.p99_rel <= fabs(s - 1.0) * (1.0 + 1e-6));
        assert_true(fabs(m.mean_ratio - s) < 1e-6);
    }

    /* Black reference: 0 against 0, inf against anything else. */
    memset(b.rgb, 0, n * sizeof(float));
    memset(a.rgb, 0, n * sizeof(float));
    m = compare_ok(&a, &b, 0.0);
    assert_true(m.relrmse == 0.0 && m.mean_rel == 0.0 && m.p99_rel == 0.0);
    a.rgb[5] = 1.0f;
    m = compare_ok(&a, &b, 0.0);
    assert_true(isinf(m.relrmse) && isinf(m.mean_rel));
    assert_true(m.p99_rel == 0.0); /* one bad value of 3600 is above the 99th percentile */
    vdbs_image_free(&a);
    vdbs_image_free(&b);
}

static void test_compare_percentile(void **state)
{
    (void)state;
    /* 300 values with relative errors i * 1e-3 / 1.001 (b = 1, so the floor is 1e-3), in a
     * shuffled order; the percentile interpolates like numpy: position 0.99 * 299. */
    vdbs_image a, b;
    alloc_ok(&a, 10, 10, 0);
    alloc_ok(&b, 10, 10, 0);
    int order[300];
    for (int i = 0; i < 300; ++i)
        order[i] = i;
    for (int i = 299; i > 0; --i) {
        int j = (int)(rng_uniform() * (i + 1));
        int t = order[i];
        order[i] = order[j];
        order[j] = t;
    }
    for (int i = 0; i < 300; ++i) {
        b.rgb[i] = 1.0f;
        a.rgb[i] = (float)(1.0 + order[i] * 1e-3);
    }
    vdbs_image_metrics m = compare_ok(&a, &b, 0.0);
    const double expect = 0.99 * 299 * 1e-3 / 1.001;
    assert_true(fabs(m.p99_rel - expect) < 1e-6);
    assert_true(fabs(m.mean_rel - 149.5e-3 / 1.001) < 1e-6);
    vdbs_image_free(&a);
    vdbs_image_free(&b);
}

static void test_compare_noise_statistics(void **state)
{
    (void)state;
    /* a = b + sqrt(se_a^2 + se_b^2) N(0,1): z is standard normal, the noise explains all of
     * the difference. */
    const int w = 64, h = 64;
    const size_t n = (size_t)w * h * 3;
    vdbs_image a, b;
    alloc_ok(&a, w, h, 1);
    alloc_ok(&b, w, h, 1);
    fill_random(&b);
    for (size_t i = 0; i < n; ++i) {
        a.se[i] = (float)(0.01 + 0.05 * rng_uniform());
        double sigma = sqrt((double)a.se[i] * a.se[i] + (double)b.se[i] * b.se[i]);
        a.rgb[i] = (float)(b.rgb[i] + sigma * rng_normal());
    }
    vdbs_image_metrics m = compare_ok(&a, &b, 0.0);
    assert_true(m.has_se);
    assert_true(fabs(m.z_rms - 1.0) < 0.05);
    assert_true(fabs(m.z_mean) < 4.0 / sqrt((double)n));
    assert_true(fabs(m.noise_share - 1.0) < 0.05);
    assert_true(m.se_image_a > 0.0 && m.se_image_b > 0.0);

    /* A 10% bias: noise explains little of it and z moves far from 0. */
    for (size_t i = 0; i < n; ++i)
        a.rgb[i] = (float)(a.rgb[i] + 0.1 * b.rgb[i]);
    m = compare_ok(&a, &b, 0.0);
    assert_true(m.noise_share < 0.5);
    assert_true(m.z_mean > 1.0);

    /* Constant image and se: the image's own relative error is se / value exactly. */
    for (size_t i = 0; i < n; ++i) {
        b.rgb[i] = 2.0f;
        b.se[i] = 0.1f;
    }
    m = compare_ok(&a, &b, 0.0);
    assert_true(fabs(m.se_image_b - 0.05) < 1e-7);

    /* Only one image with se: the other is exact, z = (a - b) / se_b. */
    free(a.se);
    a.se = NULL;
    for (size_t i = 0; i < n; ++i)
        a.rgb[i] = i % 2 ? 2.1f : 1.8f;
    m = compare_ok(&a, &b, 0.0);
    assert_true(m.has_se);
    assert_true(m.se_image_a == 0.0);
    assert_true(fabs(m.se_image_b - 0.05) < 1e-7);
    assert_true(fabs(m.z_mean - (-0.5)) < 1e-5);            /* (1 - 2) / 2 */
    assert_true(fabs(m.z_rms - sqrt(2.5)) < 1e-5);          /* sqrt((1 + 4) / 2) */
    assert_true(fabs(m.noise_share - 0.01 / 0.025) < 1e-5); /* se^2 / mean(d^2) */
    assert_int_equal(m.z_samples, (long long)n);
    vdbs_image_free(&a);
    vdbs_image_free(&b);
}

static void test_compare_mask_and_sizes(void **state)
{
    (void)state;
    const int w = 20, h = 10;
    vdbs_image a, b;
    alloc_ok(&a, w, h, 0);
    alloc_ok(&b, w, h, 0);
    /* Left half dark (luminance 0.01), right half bright (1); a is wrong only where dark. */
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            float v = x < w / 2 ? 0.01f : 1.0f;
            for (int c = 0; c < 3; ++c) {
                b.rgb[3 * (y * w + x) + c] = v;
                a.rgb[3 * (y * w + x) + c] = x < w / 2 ? 5.0f : v;
            }
        }
    }
    vdbs_image_metrics m = compare_ok(&a, &b, 0.0);
    assert_int_equal(m.samples, 3 * w * h);
    assert_true(m.relrmse > 1.0);
    m = compare_ok(&a, &b, 0.5);
    assert_int_equal(m.samples, 3 * (w / 2) * h);
    assert_true(m.relrmse == 0.0 && m.p99_rel == 0.0);
    /* Pixels exactly at the threshold stay. */
    m = compare_ok(&a, &b, 0.01f);
    assert_int_equal(m.samples, 3 * w * h);

    vdbs_error err;
    assert_int_equal(vdbs_image_compare(&a, &b, 2.0, &m, &err), VDBS_ERR_INPUT);
    vdbs_image c;
    alloc_ok(&c, w, h + 1, 0);
    assert_int_equal(vdbs_image_compare(&a, &c, 0.0, &m, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "20x10"));
    assert_non_null(strstr(err.message, "20x11"));
    vdbs_image_free(&a);
    vdbs_image_free(&b);
    vdbs_image_free(&c);
}

static void test_compare_files(void **state)
{
    (void)state;
    /* The CLI path: EXRs with se written, read back and compared like in memory. */
    vdbs_image a, b, ra, rb;
    alloc_ok(&a, 32, 16, 1);
    alloc_ok(&b, 32, 16, 1);
    fill_random(&a);
    fill_random(&b);
    const char *pa = test_tmp_path("test_image_cmp_a.exr");
    const char *pb = test_tmp_path("test_image_cmp_b.exr");
    write_ok(pa, &a, 0.0);
    write_ok(pb, &b, 0.0);
    read_ok(pa, &ra);
    read_ok(pb, &rb);
    vdbs_image_metrics m1 = compare_ok(&a, &b, 0.0), m2 = compare_ok(&ra, &rb, 0.0);
    assert_memory_equal(&m1, &m2, sizeof m1);
    vdbs_image_free(&a);
    vdbs_image_free(&b);
    vdbs_image_free(&ra);
    vdbs_image_free(&rb);
    unlink(pa);
    unlink(pb);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exr_round_trip),
        cmocka_unit_test(test_exr_every_compressed_length),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_read_errors),
        cmocka_unit_test(test_hdr_round_trip_and_cuts),
        cmocka_unit_test(test_write_errors),
        cmocka_unit_test(test_compare_self_and_scaled),
        cmocka_unit_test(test_compare_percentile),
        cmocka_unit_test(test_compare_noise_statistics),
        cmocka_unit_test(test_compare_mask_and_sizes),
        cmocka_unit_test(test_compare_files),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
