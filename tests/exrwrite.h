/* Writes small OpenEXR files of any layout for the tests (exrwrite.cpp: the C++ Imf library,
 * which, unlike OpenEXRCore 3.1.5, also compresses DWAA/DWAB and writes every tile level). */
#ifndef VDBS_TEST_EXRWRITE_H
#define VDBS_TEST_EXRWRITE_H

#ifdef __cplusplus
extern "C" {
#endif

typedef struct test_exr_spec {
    const char *channels;    /* comma-separated names in plane order ("R,G,B,A", "Y",
                                "diffuse.R,..."); "YC": R, G, B planes written as luminance and
                                chroma (Y, RY, BY) through RgbaOutputFile */
    const char *type;        /* "half", "float" or "uint" (every channel) */
    const char *compression; /* none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab */
    const char *tiles;       /* NULL: scanlines; "one", "mip" or "rip": 16 x 16 tiles */
    int data_window[4];      /* x0, y0, x1, y1 (inclusive) */
    int display_window[4];   /* the same form; all 0: the data window */
} test_exr_spec;

/* Writes planes[c] (one per channel, data-window width x height floats, row 0 on top;
 * rounded or truncated to the type) to path; lower tile levels are written black. Returns
 * NULL, or an error message (static storage). */
const char *test_exr_write(const char *path, const test_exr_spec *spec, const float *const *planes);

/* v rounded to the nearest half (what a half channel stores). */
float test_exr_half(float v);

#ifdef __cplusplus
}
#endif

#endif
