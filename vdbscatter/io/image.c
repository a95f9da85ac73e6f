/* Images: OpenEXR files (written with the OpenEXRCore C API, read through the
 * C++ Imf bridge exrmap.cpp), Radiance HDR and 8-bit sRGB PNG (stb) files, and the error
 * metrics of `vdbscatter compare`. */
#define _POSIX_C_SOURCE 200809L
#include "vdbscatter/image.h"

#include "io/exrmap.h"
#include "vdbscatter/readfile.h"
#include "vdbscatter/tempfile.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include <openexr.h>
#include <stb_image.h>
#include <stb_image_write.h>

/* ---- helpers -------------------------------------------------------------------------- */

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    return n > m && strcasecmp(path + n - m, ext) == 0;
}

/* Flushes the temporary file to disk and renames it over path; removes it on failure, and on
 * a cancel that came while it was written (the old file at path stays). */
static vdbs_status commit_temp(const char *tmp, const char *path, const vdbs_cancel *cancel,
                               vdbs_error *err)
{
    vdbs_status st = vdbs_temp_sync(tmp, path, err);
    if (st == VDBS_OK && vdbs_cancelled(cancel))
        st = vdbs_error_cancelled(err);
    if (st == VDBS_OK)
        st = vdbs_temp_rename(tmp, path, path, err);
    if (st != VDBS_OK)
        unlink(tmp);
    return st;
}

/* OpenEXRCore reports details through a callback (by default onto stderr). Library code
 * must not print, so the last message is kept per thread and folded into our error. */
static _Thread_local char exr_message[512];

static void exr_quiet_handler(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_message, sizeof exr_message, "%s",
             msg ? msg : exr_get_default_error_message(code));
}

static exr_context_initializer_t exr_initializer(void)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet_handler;
    return init;
}

static const char *exr_reason(exr_result_t rv)
{
    return exr_message[0] ? exr_message : exr_get_default_error_message(rv);
}

/* ---- EXR ------------------------------------------------------------------------------- */
/* Written here with OpenEXRCore (float ZIP scanlines); read back, like every EXR, through
 * vdbs_exrimage_read (exrmap.cpp). */

static const char *const channel_names[6] = {"R", "G", "B", "se.R", "se.G", "se.B"};

/* OpenEXR 3.1's ZIP encoder keeps its zlib output when that is exactly as long as the packed
 * pixels, and a reader takes a chunk of that length for the raw pixels: such a chunk read back
 * as garbage (OpenEXR fixed it in 3.4). The chunk is then stored raw, as the format does for
 * output that does not shrink. The library's own routine, chosen per chunk, is kept here. */
static _Thread_local exr_result_t (*exr_zip_compress)(exr_encode_pipeline_t *);

static exr_result_t exr_compress_or_raw(exr_encode_pipeline_t *enc)
{
    exr_result_t rv = exr_zip_compress(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes == enc->packed_bytes &&
        enc->compressed_buffer && enc->compressed_buffer != enc->packed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    return rv;
}

static vdbs_status exr_write(const char *path, const char *tmp, const vdbs_image *image,
                             vdbs_error *err)
{
    exr_context_initializer_t init = exr_initializer();
    exr_context_t ctx = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int have_enc = 0, part = 0;
    const int w = image->width, h = image->height;
    const int nchan = image->se ? 6 : 3;
    exr_message[0] = '\0';
    exr_result_t rv = exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_part(ctx, "rgb", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP);
    for (int c = 0; c < nchan && rv == EXR_ERR_SUCCESS; ++c)
        rv = exr_add_channel(ctx, part, channel_names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR,
                             1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctx);
    int32_t lines = 1;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
    for (int y = 0; y < h && rv == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctx, part, y, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            break;
        if (!have_enc) {
            rv = exr_encoding_initialize(ctx, part, &cinfo, &enc);
            have_enc = rv == EXR_ERR_SUCCESS;
        } else {
            rv = exr_encoding_update(ctx, part, &cinfo, &enc);
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        for (int i = 0; i < enc.channel_count; ++i) {
            exr_coding_channel_info_t *ch = &enc.channels[i];
            int c = 0;
            while (c < nchan && strcmp(ch->channel_name, channel_names[c]) != 0)
                ++c;
            const float *plane = c < 3 ? image->rgb + c : image->se + (c - 3);
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = 3 * w * (int32_t)sizeof(float);
            ch->encode_from_ptr = (const uint8_t *)(plane + (size_t)y * w * 3);
        }
        rv = exr_encoding_choose_default_routines(ctx, part, &enc);
        if (rv == EXR_ERR_SUCCESS && enc.compress_fn) {
            exr_zip_compress = enc.compress_fn;
            enc.compress_fn = exr_compress_or_raw;
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctx, part, &enc);
    }
    if (have_enc) {
        exr_result_t rd = exr_encoding_destroy(ctx, &enc);
        if (rv == EXR_ERR_SUCCESS)
            rv = rd;
    }
    if (ctx) {
        /* exr_finish writes the chunk offset table, so its result matters too. */
        exr_result_t rf = exr_finish(&ctx);
        if (rv == EXR_ERR_SUCCESS)
            rv = rf;
    }
    if (rv != EXR_ERR_SUCCESS) {
        unlink(tmp);
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: writing OpenEXR failed: %s", path,
                              exr_reason(rv));
    }
    return VDBS_OK;
}

/* ---- PNG ------------------------------------------------------------------------------- */

static double srgb_encode(double v)
{
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

static double srgb_decode(double s)
{
    return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
}

static vdbs_status png_write(const char *path, const char *tmp, const vdbs_image *image,
                             double exposure_ev, vdbs_error *err)
{
    const size_t n = (size_t)image->width * image->height * 3;
    unsigned char *bytes = malloc(n);
    if (!bytes)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory", path);
    const double scale = exp2(exposure_ev);
    for (size_t i = 0; i < n; ++i) {
        double v = image->rgb[i] * scale;
        /* NaN fails both comparisons and becomes black, like a negative value. */
        v = v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
        bytes[i] = (unsigned char)(srgb_encode(v) * 255.0 + 0.5);
    }
    int ok = stbi_write_png(tmp, image->width, image->height, 3, bytes, image->width * 3);
    free(bytes);
    if (!ok) {
        unlink(tmp);
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: cannot write PNG to %s", path, tmp);
    }
    return VDBS_OK;
}

static vdbs_status png_read(const char *path, vdbs_image *image, vdbs_error *err)
{
    int w = 0, h = 0, comp = 0;
    const int is16 = stbi_is_16_bit(path);
    void *data = is16 ? (void *)stbi_load_16(path, &w, &h, &comp, 3)
                      : (void *)stbi_load(path, &w, &h, &comp, 3);
    if (!data)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: corrupt or unsupported PNG file: %s", path,
                              stbi_failure_reason());
    vdbs_status st = vdbs_image_alloc(image, w, h, 0, err);
    if (st == VDBS_OK) {
        const size_t n = (size_t)w * h * 3;
        if (is16) {
            const unsigned short *p = data;
            for (size_t i = 0; i < n; ++i)
                image->rgb[i] = (float)srgb_decode(p[i] / 65535.0);
        } else {
            float table[256];
            for (int b = 0; b < 256; ++b)
                table[b] = (float)srgb_decode(b / 255.0);
            const unsigned char *p = data;
            for (size_t i = 0; i < n; ++i)
                image->rgb[i] = table[p[i]];
        }
    }
    stbi_image_free(data);
    return st;
}

/* Radiance RGBE (.hdr), linear: environment maps for other tools and the tests. */
static vdbs_status hdr_write(const char *path, const char *tmp, const vdbs_image *image,
                             vdbs_error *err)
{
    if (!stbi_write_hdr(tmp, image->width, image->height, 3, image->rgb)) {
        unlink(tmp);
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: cannot write Radiance HDR to %s", path, tmp);
    }
    return VDBS_OK;
}

/* A byte cursor that reads 0 past the end, as stb_image's reader does, so that the check
 * below walks the file exactly as stb will. */
typedef struct hdr_cursor {
    const unsigned char *bytes;
    size_t size, at;
} hdr_cursor;

static int hdr_get8(hdr_cursor *c)
{
    return c->at < c->size ? c->bytes[c->at++] : 0;
}

/* One header line, stb's way: at most 1023 characters kept, the rest of the line skipped. */
static void hdr_line(hdr_cursor *c, char *line, size_t cap)
{
    size_t len = 0;
    int ch = hdr_get8(c);
    while (c->at < c->size && ch != '\n') {
        line[len++] = (char)ch;
        if (len == cap - 1) {
            while (c->at < c->size && hdr_get8(c) != '\n')
                ;
            break;
        }
        ch = hdr_get8(c);
    }
    line[len] = 0;
}

/* Debian's stb_image loops forever on a run-length scanline that holds a zero count, which is
 * what every truncated scanline reads as (bytes past the end read 0). Walks the scanlines
 * stb will decode and refuses a zero count or a scanline cut short; anything else stb
 * reports itself. Returns the bad scanline's number, or -1 when stb may read the file. */
static long hdr_bad_scanline(const unsigned char *bytes, size_t size)
{
    hdr_cursor c = {bytes, size, 0};
    char line[1024];
    hdr_line(&c, line, sizeof line); /* "#?RADIANCE": stb checks it */
    do
        hdr_line(&c, line, sizeof line);
    while (line[0] && c.at < c.size);
    hdr_line(&c, line, sizeof line);
    long height = 0, width = 0;
    if (sscanf(line, "-Y %ld +X %ld", &height, &width) != 2 || width < 8 || width >= 32768)
        return -1; /* another layout, or flat pixels: stb refuses or reads without runs */
    for (long row = 0; row < height; ++row) {
        if (c.size - c.at < 4)
            return row;
        const int c1 = hdr_get8(&c), c2 = hdr_get8(&c), hi = hdr_get8(&c);
        if (c1 != 2 || c2 != 2 || (hi & 0x80))
            return -1; /* flat pixels from here on */
        if (((long)hi << 8 | hdr_get8(&c)) != width)
            return -1; /* stb refuses the length */
        for (int channel = 0; channel < 4; ++channel) {
            for (long x = 0; x < width;) {
                if (c.at >= c.size)
                    return row;
                int count = hdr_get8(&c);
                const int run = count > 128;
                count -= run ? 128 : 0;
                if (count == 0)
                    return row;
                if (count > width - x)
                    return -1; /* stb refuses the run */
                const size_t need = run ? 1u : (size_t)count;
                if (c.size - c.at < need)
                    return row;
                c.at += need;
                x += count;
            }
        }
    }
    return -1;
}

/* Radiance RGBE (.hdr): linear float radiance as stored. The file is read once into memory,
 * checked, and decoded from the same bytes. */
static vdbs_status hdr_read(const char *path, vdbs_image *image, vdbs_error *err)
{
    char *bytes = NULL;
    size_t size = 0;
    vdbs_status st = vdbs_read_file(path, NULL, INT32_MAX, &bytes, &size, err);
    if (st != VDBS_OK)
        return st;
    const long bad_row = hdr_bad_scanline((const unsigned char *)bytes, size);
    if (bad_row >= 0) {
        free(bytes);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: corrupt Radiance HDR file: run-length scanline %ld is "
                              "truncated or holds a zero-length run",
                              path, bad_row);
    }
    int w = 0, h = 0, comp = 0;
    float *data = stbi_loadf_from_memory((const unsigned char *)bytes, (int)size, &w, &h, &comp, 3);
    free(bytes);
    if (!data)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: corrupt or unsupported Radiance HDR file: %s", path,
                              stbi_failure_reason());
    st = vdbs_image_alloc(image, w, h, 0, err);
    if (st == VDBS_OK)
        memcpy(image->rgb, data, sizeof(float) * 3 * (size_t)w * (size_t)h);
    stbi_image_free(data);
    return st;
}

/* ---- public I/O ------------------------------------------------------------------------ */

vdbs_status vdbs_image_write(const char *path, const vdbs_image *image, double exposure_ev,
                             vdbs_error *err)
{
    return vdbs_image_write_cancel(path, image, exposure_ev, NULL, err);
}

vdbs_status vdbs_image_write_cancel(const char *path, const vdbs_image *image, double exposure_ev,
                                    const vdbs_cancel *cancel, vdbs_error *err)
{
    const int exr = has_extension(path, ".exr"), png = has_extension(path, ".png");
    const int hdr = has_extension(path, ".hdr");
    if (!exr && !png && !hdr)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: unknown image extension (use .exr, .png or .hdr)", path);
    if (!image || !image->rgb || image->width <= 0 || image->height <= 0)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "%s: empty image", path);
    if (png && !isfinite(exposure_ev))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: exposure is not finite", path);
    if (vdbs_cancelled(cancel))
        return vdbs_error_cancelled(err);
    char *tmp = vdbs_temp_path(path);
    if (!tmp)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory", path);
    vdbs_temp_remove_stale(path);
    vdbs_fault_point("before-write", NULL);
    vdbs_status st = exr   ? exr_write(path, tmp, image, err)
                     : hdr ? hdr_write(path, tmp, image, err)
                           : png_write(path, tmp, image, exposure_ev, err);
    if (st == VDBS_OK)
        st = commit_temp(tmp, path, cancel, err);
    free(tmp);
    return st;
}

vdbs_status vdbs_image_kind_of(const char *path, vdbs_image_kind *kind, vdbs_error *err)
{
    *kind = VDBS_IMAGE_UNKNOWN;
    FILE *f = fopen(path, "rb");
    if (!f)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: cannot open: %s", path, strerror(errno));
    unsigned char magic[8] = {0};
    size_t got = fread(magic, 1, sizeof magic, f);
    fclose(f);
    /* The content decides the format, so a misnamed file still reads. */
    static const unsigned char exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    static const unsigned char png_magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (got >= 4 && memcmp(magic, exr_magic, 4) == 0)
        *kind = VDBS_IMAGE_EXR;
    else if (got == 8 && memcmp(magic, png_magic, 8) == 0)
        *kind = VDBS_IMAGE_PNG;
    else if (got >= 2 && magic[0] == '#' && magic[1] == '?')
        *kind = VDBS_IMAGE_HDR; /* "#?RADIANCE" or "#?RGBE" */
    return VDBS_OK;
}

double vdbs_image_noise(const vdbs_image *image)
{
    double s2 = 0.0, l2 = 0.0;
    const long long n = 3ll * image->width * image->height;
    for (long long i = 0; image->se && i < n; ++i) {
        s2 += (double)image->se[i] * image->se[i];
        l2 += (double)image->rgb[i] * image->rgb[i];
    }
    return l2 > 0.0 ? sqrt(s2 / l2) : 0.0;
}

vdbs_status vdbs_image_read(const char *path, vdbs_image *image, vdbs_error *err)
{
    memset(image, 0, sizeof *image);
    vdbs_image_kind kind;
    vdbs_status st = vdbs_image_kind_of(path, &kind, err);
    if (st != VDBS_OK)
        return st;
    switch (kind) {
    case VDBS_IMAGE_EXR:
        /* Imf, like environment maps: OpenEXRCore 3.1.5's decoder crashed on half RGBA ZIP
         * files and cannot decompress DWAA/DWAB (docs/envmap.md). */
        return vdbs_exrimage_read(path, image, err);
    case VDBS_IMAGE_PNG:
        return png_read(path, image, err);
    case VDBS_IMAGE_HDR:
        return hdr_read(path, image, err);
    default:
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: not an OpenEXR, Radiance HDR or PNG image",
                              path);
    }
}

/* ---- comparison ------------------------------------------------------------------------ */

/* k-th smallest of x[0..n) (reorders x): Hoare partitioning, which splits runs of equal
 * values evenly, so images with many identical errors stay O(n). */
static double select_kth(double *x, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        double pivot = x[lo + (hi - lo) / 2];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (x[i] < pivot)
                ++i;
            while (x[j] > pivot)
                --j;
            if (i <= j) {
                double t = x[i];
                x[i] = x[j];
                x[j] = t;
                ++i;
                if (j == 0)
                    break;
                --j;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return x[k];
    }
    return x[k];
}

/* Linear interpolation between order statistics at q (n-1), as numpy's default. */
static double percentile(double *x, size_t n, double q)
{
    double pos = q * (double)(n - 1);
    size_t k = (size_t)pos;
    double frac = pos - (double)k;
    double lo = select_kth(x, n, k);
    if (frac == 0.0 || k + 1 >= n)
        return lo;
    /* After selection every element above index k is >= x[k]: the next statistic is their
     * minimum. */
    double hi = x[k + 1];
    for (size_t i = k + 2; i < n; ++i)
        if (x[i] < hi)
            hi = x[i];
    return lo + frac * (hi - lo);
}

/* num/den where 0/0 means "no error and no scale" = 0 and x/0 is +inf. */
static double ratio(double num, double den)
{
    if (den > 0.0)
        return num / den;
    return num == 0.0 ? 0.0 : INFINITY;
}

vdbs_status vdbs_image_compare(const vdbs_image *a, const vdbs_image *b, double mask_below,
                               vdbs_image_metrics *metrics, vdbs_error *err)
{
    memset(metrics, 0, sizeof *metrics);
    if (a->width != b->width || a->height != b->height)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "image sizes differ: %dx%d against reference %dx%d", a->width,
                              a->height, b->width, b->height);
    const size_t pixels = (size_t)a->width * a->height;
    unsigned char *keep = malloc(pixels ? pixels : 1);
    if (!keep)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory comparing images");
    size_t kept = 0;
    double sum_b = 0.0;
    for (size_t p = 0; p < pixels; ++p) {
        const float *rb = b->rgb + 3 * p;
        double lum = 0.2126 * rb[0] + 0.7152 * rb[1] + 0.0722 * rb[2];
        keep[p] = !(mask_below > 0.0) || lum >= mask_below;
        if (keep[p]) {
            ++kept;
            sum_b += fabs(rb[0]) + fabs(rb[1]) + fabs(rb[2]);
        }
    }
    if (kept == 0) {
        free(keep);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "no pixel of the reference has luminance >= %g",
                              mask_below);
    }
    const size_t n = 3 * kept;
    double *rel = malloc(n * sizeof *rel);
    if (!rel) {
        free(keep);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory comparing images");
    }
    /* mean(|b|) rather than mean(b): the same for radiance, and never a negative floor. */
    const double floor_b = 1e-3 * sum_b / (double)n;
    /* An image without se channels is deterministic: its standard error is 0, so z is
     * still defined (a reference against a ray-marched image, say). */
    const int has_se = a->se || b->se;
    double sum_d2 = 0.0, sum_b2 = 0.0, sum_a2 = 0.0, sum_rel = 0.0, sum_va = 0.0, sum_vb = 0.0;
    double sum_sa2 = 0.0, sum_sb2 = 0.0, sum_z = 0.0, sum_z2 = 0.0;
    size_t m = 0, nz = 0;
    for (size_t p = 0; p < pixels; ++p) {
        if (!keep[p])
            continue;
        for (size_t i = 3 * p; i < 3 * p + 3; ++i) {
            const double va = a->rgb[i], vb = b->rgb[i], d = va - vb;
            sum_d2 += d * d;
            sum_b2 += vb * vb;
            sum_a2 += va * va;
            sum_va += va;
            sum_vb += vb;
            double r = ratio(fabs(d), fabs(vb) + floor_b);
            if (isnan(r))
                r = INFINITY; /* NaN pixels count as the worst error, and keep selection sane */
            rel[m++] = r;
            sum_rel += r;
            const double sa2 = a->se ? (double)a->se[i] * a->se[i] : 0.0;
            const double sb2 = b->se ? (double)b->se[i] * b->se[i] : 0.0;
            sum_sa2 += sa2;
            sum_sb2 += sb2;
            if (has_se && sa2 + sb2 > 0.0) {
                const double z = d / sqrt(sa2 + sb2);
                sum_z += z;
                sum_z2 += z * z;
                ++nz;
            }
        }
    }
    free(keep);
    metrics->samples = (long long)n;
    metrics->relrmse = sqrt(ratio(sum_d2, sum_b2));
    metrics->mean_rel = sum_rel / (double)n;
    metrics->mean_ratio = ratio(sum_va, sum_vb);
    metrics->p99_rel = percentile(rel, n, 0.99);
    free(rel);
    metrics->has_se = has_se;
    if (has_se) {
        metrics->noise_share = ratio(sum_sa2 + sum_sb2, sum_d2);
        metrics->z_mean = nz ? sum_z / (double)nz : NAN;
        metrics->z_rms = nz ? sqrt(sum_z2 / (double)nz) : NAN;
        metrics->z_samples = (long long)nz;
    }
    if (a->se)
        metrics->se_image_a = sqrt(ratio(sum_sa2, sum_a2));
    if (b->se)
        metrics->se_image_b = sqrt(ratio(sum_sb2, sum_b2));
    return VDBS_OK;
}
