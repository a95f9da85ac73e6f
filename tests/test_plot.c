/* Charts (plot.h): the font against hand-drawn glyphs, text inside its box, data points at
 * the pixels of the documented mapping in their exact colours, the frame and ticks where the
 * layout says, automatic ranges, unusable values skipped, every error class, and the PNG
 * read back equal to the rendered floats. Also writes a tradeoff-like chart for the eye
 * (tmp/plot_tradeoff.png). */
#include "testutil.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/image.h"
#include "vdbscatter/plot.h"

/* image.c's sRGB decoding: the float a PNG byte becomes. */
static float lin(unsigned char b)
{
    double s = b / 255.0;
    return (float)(s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4));
}

static const float *pixel(const vdbs_image *im, int x, int y)
{
    assert_true(x >= 0 && x < im->width && y >= 0 && y < im->height);
    return im->rgb + ((size_t)y * im->width + x) * 3;
}

static int is_rgb(const vdbs_image *im, int x, int y, unsigned hex)
{
    const float *p = pixel(im, x, y);
    return p[0] == lin((unsigned char)(hex >> 16)) && p[1] == lin((unsigned char)(hex >> 8)) &&
           p[2] == lin((unsigned char)hex);
}

static int is_white(const vdbs_image *im, int x, int y)
{
    return is_rgb(im, x, y, 0xFFFFFFu);
}

/* Dark: every channel below sRGB 0x40. */
static int is_dark(const vdbs_image *im, int x, int y)
{
    const float *p = pixel(im, x, y);
    return p[0] < lin(0x40) && p[1] < lin(0x40) && p[2] < lin(0x40);
}

static long count_rgb(const vdbs_image *im, unsigned hex)
{
    long n = 0;
    for (int y = 0; y < im->height; ++y)
        for (int x = 0; x < im->width; ++x)
            n += is_rgb(im, x, y, hex);
    return n;
}

static void render_ok(const vdbs_plot_desc *d, vdbs_image *im, vdbs_plot_layout *lay)
{
    vdbs_error err;
    if (vdbs_plot_render(d, im, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_plot_layout_of(d, lay, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

/* The documented mapping, written out here rather than taken from vdbs_plot_map. */
static void expect_pixel(const vdbs_plot_layout *l, double x, double y, int *px, int *py)
{
    const double tx = l->log_x ? (log10(x) - log10(l->x_min)) / (log10(l->x_max) - log10(l->x_min))
                               : (x - l->x_min) / (l->x_max - l->x_min);
    const double ty = l->log_y ? (log10(y) - log10(l->y_min)) / (log10(l->y_max) - log10(l->y_min))
                               : (y - l->y_min) / (l->y_max - l->y_min);
    *px = (int)floor(l->left + tx * (l->right - l->left) + 0.5);
    *py = (int)floor(l->bottom - ty * (l->bottom - l->top) + 0.5);
}

static void set_rgb(vdbs_plot_series *s, unsigned hex)
{
    s->rgb[0] = (unsigned char)(hex >> 16);
    s->rgb[1] = (unsigned char)(hex >> 8);
    s->rgb[2] = (unsigned char)hex;
}

static void test_font(void **state)
{
    (void)state;
    /* 'L', '1' and 'g' drawn by hand: rows of 5 columns, '#' set. */
    static const char *const L[9] = {"#....", "#....", "#....", "#....", "#....",
                                     "#....", "#####", ".....", "....."};
    static const char *const one[9] = {"..#..", ".##..", "..#..", "..#..", "..#..",
                                       "..#..", ".###.", ".....", "....."};
    static const char *const g[9] = {".....", ".....", ".####", "#...#", "#...#",
                                     "#...#", ".####", "....#", ".###."};
    const struct {
        int c;
        const char *const *rows;
    } known[3] = {{'L', L}, {'1', one}, {'g', g}};
    for (int k = 0; k < 3; ++k) {
        const unsigned char *rows = vdbs_plot_glyph(known[k].c);
        assert_non_null(rows);
        for (int r = 0; r < VDBS_PLOT_GLYPH_H; ++r)
            for (int c = 0; c < VDBS_PLOT_GLYPH_W; ++c)
                if (((rows[r] >> (4 - c)) & 1) != (known[k].rows[r][c] == '#'))
                    fail_msg("glyph '%c' row %d column %d", known[k].c, r, c);
    }
    const unsigned char *space = vdbs_plot_glyph(' ');
    assert_non_null(space);
    for (int r = 0; r < VDBS_PLOT_GLYPH_H; ++r)
        assert_int_equal(space[r], 0);
    for (int c = '!'; c <= '~'; ++c) {
        const unsigned char *rows = vdbs_plot_glyph(c);
        int bits = 0;
        for (int r = 0; r < VDBS_PLOT_GLYPH_H; ++r) {
            assert_int_equal(rows[r] & ~0x1F, 0);
            bits += rows[r] != 0;
        }
        if (bits == 0)
            fail_msg("glyph '%c' is empty", c);
    }
    assert_null(vdbs_plot_glyph(31));
    assert_null(vdbs_plot_glyph(127));
    assert_int_equal(vdbs_plot_text_width("", 1), 0);
    assert_int_equal(vdbs_plot_text_width(NULL, 1), 0);
    assert_int_equal(vdbs_plot_text_width("A", 1), 5);
    assert_int_equal(vdbs_plot_text_width("abc", 2), (3 * 6 - 1) * 2);
}

static void test_text_box(void **state)
{
    (void)state;
    vdbs_image im;
    vdbs_error err;
    assert_int_equal(vdbs_image_alloc(&im, 60, 40, 0, &err), VDBS_OK);
    const unsigned char red[3] = {200, 10, 20};
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 60; ++x)
            memcpy((float *)pixel(&im, x, y), (float[3]){lin(255), lin(255), lin(255)},
                   sizeof(float[3]));
    /* A space draws nothing. */
    vdbs_plot_draw_text(&im, 3, 3, " ", 2, red);
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 60; ++x)
            assert_true(is_white(&im, x, y));
    /* 'F' (not mirror-symmetric) at scale 2 stays in its 10 x 18 box and fills it as the
     * glyph says. */
    const int x0 = 7, y0 = 5;
    vdbs_plot_draw_text(&im, x0, y0, "F", 2, red);
    long inside = 0;
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 60; ++x) {
            if (is_white(&im, x, y))
                continue;
            assert_true(is_rgb(&im, x, y, 0xC80A14u));
            if (x < x0 || x >= x0 + 10 || y < y0 || y >= y0 + 18)
                fail_msg("pixel %d,%d outside the glyph box is drawn", x, y);
            ++inside;
        }
    /* 'F': ##### #.... #.... ####. #.... #.... #....: 5 + 1 + 1 + 4 + 1 + 1 + 1 = 14 bits */
    assert_int_equal(inside, 14 * 4);
    assert_true(is_rgb(&im, x0 + 9, y0 + 1, 0xC80A14u)); /* row 0 column 4 */
    assert_true(is_white(&im, x0 + 9, y0 + 3));          /* row 1 column 4 */
    assert_true(is_rgb(&im, x0 + 1, y0 + 3, 0xC80A14u)); /* row 1 column 0 */
    assert_true(is_rgb(&im, x0 + 7, y0 + 6, 0xC80A14u)); /* row 3 column 3 */
    assert_true(is_white(&im, x0 + 8, y0 + 6));          /* row 3 column 4 */
    /* Clipping: text half off the image draws its visible part and no more. */
    vdbs_plot_draw_text(&im, 57, 37, "W", 1, red);
    assert_true(is_rgb(&im, 57, 37, 0xC80A14u));
    vdbs_image_free(&im);
}

/* Points with explicit colours on fixed log ranges: each disc at its computed pixel, the
 * line between, frame and decade ticks dark where the layout puts them. */
static void test_points_and_axes(void **state)
{
    (void)state;
    const double x[3] = {2.0, 10.0, 50.0}, y[3] = {0.5, 0.1, 0.02};
    vdbs_plot_series s[2] = {{0}};
    s[0].name = "a";
    s[0].x = x;
    s[0].y = y;
    s[0].count = 3;
    set_rgb(&s[0], 0x10A050u);
    const double x2[1] = {1.5}, y2[1] = {0.015};
    s[1].name = "b";
    s[1].x = x2;
    s[1].y = y2;
    s[1].count = 1; /* automatic: the first palette colour */
    vdbs_plot_desc d = {0};
    d.title = "Title";
    d.xlabel = "time (s)";
    d.ylabel = "error";
    d.log_x = d.log_y = 1;
    d.x_min = 1.0;
    d.x_max = 100.0;
    d.y_min = 0.01;
    d.y_max = 1.0;
    d.legend = VDBS_PLOT_LEGEND_NONE;
    d.series = s;
    d.series_count = 2;
    vdbs_image im;
    vdbs_plot_layout l;
    render_ok(&d, &im, &l);
    assert_int_equal(im.width, 800);
    assert_int_equal(im.height, 560);
    assert_true(l.left > 20 && l.right < 790 && l.top > 20 && l.bottom < 540);
    assert_true(l.right - l.left > 600 && l.bottom - l.top > 400);
    assert_true(l.x_min == 1.0 && l.x_max == 100.0 && l.y_min == 0.01 && l.y_max == 1.0);

    int px[3], py[3];
    for (int i = 0; i < 3; ++i) {
        expect_pixel(&l, x[i], y[i], &px[i], &py[i]);
        double mx, my;
        assert_true(vdbs_plot_map(&l, x[i], y[i], &mx, &my));
        assert_int_equal((int)floor(mx + 0.5), px[i]);
        assert_int_equal((int)floor(my + 0.5), py[i]);
        /* the disc of radius 3 centred there, in a white ring at 4 (drawn over its lines) */
        assert_true(is_rgb(&im, px[i], py[i], 0x10A050u));
        for (int k = -1; k <= 1; k += 2) {
            assert_true(is_rgb(&im, px[i] + 3 * k, py[i], 0x10A050u));
            assert_true(is_rgb(&im, px[i], py[i] + 3 * k, 0x10A050u));
            assert_true(is_white(&im, px[i] + 4 * k, py[i]));
            assert_true(is_white(&im, px[i], py[i] + 4 * k));
        }
    }
    /* x = 10 is the middle of 1..100, y = 0.1 the middle of 0.01..1. */
    assert_true(abs(px[1] - (l.left + l.right) / 2) <= 1);
    assert_true(abs(py[1] - (l.top + l.bottom) / 2) <= 1);
    /* the line between the first two discs, half way */
    assert_true(is_rgb(&im, (px[0] + px[1]) / 2, (py[0] + py[1]) / 2, 0x10A050u));
    /* the automatic series: palette colour one (0x1F77B4) */
    int qx, qy;
    expect_pixel(&l, 1.5, 0.015, &qx, &qy);
    assert_true(is_rgb(&im, qx, qy, 0x1F77B4u));
    /* frame: dark along all four sides, away from the data */
    const int cx = (l.left + l.right) / 2 + 37, cy = (l.top + l.bottom) / 2 + 23;
    assert_true(is_dark(&im, l.left, cy));
    assert_true(is_dark(&im, l.right, cy));
    assert_true(is_dark(&im, cx, l.top));
    assert_true(is_dark(&im, cx, l.bottom));
    /* decade ticks below the frame at x = 1, 10, 100 and left of it at y = 0.01, 0.1, 1;
     * a 2x minor tick is shorter than a decade tick */
    for (int k = 0; k < 3; ++k) {
        int tx, ty;
        expect_pixel(&l, pow(10.0, k), pow(10.0, k - 2), &tx, &ty);
        assert_true(is_dark(&im, tx, l.bottom + 4));
        assert_true(is_dark(&im, l.left - 4, ty));
    }
    int mx2, my2;
    expect_pixel(&l, 20.0, 0.2, &mx2, &my2);
    assert_true(is_dark(&im, mx2, l.bottom + 2) && !is_dark(&im, mx2, l.bottom + 4));
    assert_true(is_dark(&im, l.left - 2, my2) && !is_dark(&im, l.left - 4, my2));
    /* nothing but background in the frame away from data and grid: a corner */
    assert_true(is_white(&im, l.right - 3, l.top + 3));
    vdbs_image_free(&im);
}

static void layout_ok(const vdbs_plot_desc *d, vdbs_plot_layout *l)
{
    vdbs_error err;
    if (vdbs_plot_layout_of(d, l, &err) != VDBS_OK)
        fail_msg("%s", err.message);
}

static void assert_close(double a, double b)
{
    if (!(fabs(a - b) <= 1e-12 * fabs(b)))
        fail_msg("%.17g != %.17g", a, b);
}

static void test_auto_range(void **state)
{
    (void)state;
    const double x[4] = {0.5, 3.0, 12.0, 40.0}, y[4] = {0.5, 0.1, 0.05, 0.02};
    vdbs_plot_series s = {0};
    s.x = x;
    s.y = y;
    s.count = 4;
    vdbs_plot_desc d = {0};
    d.log_x = d.log_y = 1;
    d.series = &s;
    d.series_count = 1;
    vdbs_plot_layout l;
    layout_ok(&d, &l);
    assert_close(l.x_min, 0.1);
    assert_close(l.x_max, 100.0);
    assert_close(l.y_min, 0.01);
    assert_close(l.y_max, 1.0);
    /* powers of ten are their own bounds */
    const double xp[2] = {0.01, 10.0};
    s.x = xp;
    s.count = 2;
    layout_ok(&d, &l);
    assert_close(l.x_min, 0.01);
    assert_close(l.x_max, 10.0);
    /* one power of ten alone: a decade either side */
    const double one[1] = {1.0};
    s.x = one;
    s.y = one;
    s.count = 1;
    layout_ok(&d, &l);
    assert_close(l.x_min, 0.1);
    assert_close(l.x_max, 10.0);
    /* linear: whole steps of nice_step(span / 5): 0.3 .. 9.7 in steps of 2 -> 0 .. 10 */
    const double xl[2] = {0.3, 9.7}, yl[2] = {-0.7, 0.45};
    s.x = xl;
    s.y = yl;
    s.count = 2;
    d.log_x = d.log_y = 0;
    layout_ok(&d, &l);
    assert_close(l.x_min, 0.0);
    assert_close(l.x_max, 10.0);
    assert_close(l.y_min, -1.0); /* span 1.15 / 5 = 0.23 -> steps of 0.5 */
    assert_close(l.y_max, 0.5);
    vdbs_image im;
    render_ok(&d, &im, &l);
    int px, py;
    expect_pixel(&l, 9.7, 0.45, &px, &py);
    assert_true(is_rgb(&im, px, py, 0x1F77B4u));
    vdbs_image_free(&im);
}

/* Unusable values are skipped; with none left the chart is empty, not an error. */
static void test_unusable_values(void **state)
{
    (void)state;
    const double x[6] = {NAN, 2.0, -1.0, 0.0, INFINITY, 30.0};
    const double y[6] = {0.1, 0.2, 0.1, 0.1, 0.1, 0.03};
    vdbs_plot_series s = {0};
    s.name = "skips";
    s.x = x;
    s.y = y;
    s.count = 6;
    vdbs_plot_desc d = {0};
    d.log_x = d.log_y = 1;
    d.series = &s;
    d.series_count = 1;
    vdbs_image im;
    vdbs_plot_layout l;
    render_ok(&d, &im, &l);
    assert_close(l.x_min, 1.0);
    assert_close(l.x_max, 100.0);
    assert_close(l.y_min, 0.01);
    assert_close(l.y_max, 1.0);
    int ax, ay, bx, by;
    expect_pixel(&l, 2.0, 0.2, &ax, &ay);
    expect_pixel(&l, 30.0, 0.03, &bx, &by);
    assert_true(is_rgb(&im, ax, ay, 0x1F77B4u));
    assert_true(is_rgb(&im, bx, by, 0x1F77B4u));
    assert_true(is_rgb(&im, (ax + bx) / 2, (ay + by) / 2, 0x1F77B4u)); /* joined over the gap */
    assert_false(vdbs_plot_map(&l, -1.0, 0.1, NULL, NULL));
    assert_false(vdbs_plot_map(&l, 1.0, NAN, NULL, NULL));
    vdbs_image_free(&im);

    /* nothing usable: an empty chart over 1 .. 10, no series colour in the frame, but the
     * legend keeps its entry (the colour appears only in the legend box) */
    const double bad[3] = {0.0, -2.0, NAN};
    s.x = bad;
    s.y = y;
    s.count = 3;
    d.legend = VDBS_PLOT_LEGEND_NONE;
    render_ok(&d, &im, &l);
    assert_close(l.x_min, 1.0);
    assert_close(l.x_max, 10.0);
    assert_int_equal(count_rgb(&im, 0x1F77B4u), 0);
    vdbs_image_free(&im);
    d.legend = 0;
    render_ok(&d, &im, &l);
    assert_true(count_rgb(&im, 0x1F77B4u) > 0);
    vdbs_image_free(&im);

    /* no series at all */
    d.series = NULL;
    d.series_count = 0;
    render_ok(&d, &im, &l);
    assert_int_equal(im.width, 800);
    vdbs_image_free(&im);
}

/* Extremes never crash: decades from 1e-320 to 1e308, points far outside explicit ranges,
 * linear spans that overflow. The chart still comes out with its frame. */
static void test_extremes(void **state)
{
    (void)state;
    const double x[5] = {5e-324, 1e-300, 1.0, 1e300, DBL_MAX};
    const double y[5] = {DBL_MAX, 1e200, 1.0, 1e-200, 5e-324};
    const char *const labels[5] = {"a", "b", "c", "d", "e"};
    vdbs_plot_series s[2] = {{0}};
    s[0].name = "wide";
    s[0].x = x;
    s[0].y = y;
    s[0].labels = labels;
    s[0].count = 5;
    s[1] = s[0];
    s[1].style = VDBS_PLOT_DASHED;
    vdbs_plot_desc d = {0};
    d.log_x = d.log_y = 1;
    d.series = s;
    d.series_count = 2;
    for (int pass = 0; pass < 4; ++pass) {
        if (pass == 1) { /* explicit ranges: every point but (1, 1) far outside */
            d.x_min = d.y_min = 0.5;
            d.x_max = d.y_max = 2.0;
        } else if (pass == 2) { /* linear: spans of 2 DBL_MAX */
            d.log_x = d.log_y = 0;
            d.x_min = d.x_max = d.y_min = d.y_max = 0.0;
        } else if (pass == 3) {
            d.x_min = d.y_min = 0.5;
            d.x_max = d.y_max = 2.0;
        }
        vdbs_image im;
        vdbs_plot_layout l;
        render_ok(&d, &im, &l);
        assert_true(is_dark(&im, l.left, (l.top + l.bottom) / 2));
        assert_true(is_dark(&im, (l.left + l.right) / 2 + 3, l.bottom));
        if (pass == 1 || pass == 3) { /* the one point inside, at the middle */
            int px, py;
            expect_pixel(&l, 1.0, 1.0, &px, &py);
            assert_true(is_rgb(&im, px, py, 0x7F7F7Fu)); /* the dashed series, drawn last */
        }
        vdbs_image_free(&im);
    }
}

static void expect_error(const vdbs_plot_desc *d, vdbs_status want, const char *words)
{
    vdbs_image im;
    vdbs_error err = {{0}};
    assert_int_equal(vdbs_plot_render(d, &im, &err), want);
    assert_null(im.rgb);
    if (words && !strstr(err.message, words))
        fail_msg("message \"%s\" lacks \"%s\"", err.message, words);
    vdbs_plot_layout l;
    assert_int_equal(vdbs_plot_layout_of(d, &l, &err), want);
}

static void test_errors(void **state)
{
    (void)state;
    vdbs_image im;
    vdbs_error err;
    assert_int_equal(vdbs_plot_render(NULL, &im, &err), VDBS_ERR_INTERNAL);
    const double v[2] = {1.0, 2.0};
    vdbs_plot_series s = {0};
    s.x = v;
    s.count = 2; /* no y */
    vdbs_plot_desc d = {0};
    d.series = &s;
    d.series_count = 1;
    expect_error(&d, VDBS_ERR_INTERNAL, "series 0");
    s.y = v;
    s.count = -1;
    expect_error(&d, VDBS_ERR_INTERNAL, "series 0");
    s.count = 2;
    s.style = 9;
    expect_error(&d, VDBS_ERR_INTERNAL, "style 9");
    s.style = VDBS_PLOT_DASHED;
    d.series_count = 2;
    d.series = NULL;
    expect_error(&d, VDBS_ERR_INTERNAL, NULL);
    d.series = &s;
    d.series_count = 1;
    d.width = 100;
    expect_error(&d, VDBS_ERR_INPUT, "100x560");
    d.width = 9000;
    expect_error(&d, VDBS_ERR_INPUT, "9000x560");
    d.width = 0;
    d.log_x = 1;
    d.x_min = 0.0;
    d.x_max = 10.0;
    expect_error(&d, VDBS_ERR_INPUT, "x range");
    d.x_min = 5.0;
    d.x_max = 5.0;
    expect_error(&d, VDBS_ERR_INPUT, "x range");
    d.x_min = d.x_max = 0.0;
    d.y_min = 3.0; /* y_max left 0: an empty range, not automatic */
    expect_error(&d, VDBS_ERR_INPUT, "y range");
    d.y_min = 0.0;
    /* the smallest size still works */
    d.width = 160;
    d.height = 120;
    vdbs_plot_layout l;
    render_ok(&d, &im, &l);
    vdbs_image_free(&im);
}

/* The PNG holds exactly the rendered colours: read back, every float equal. */
static void test_png_round_trip(void **state)
{
    (void)state;
    const double x[3] = {0.7, 4.0, 25.0}, y[3] = {0.3, 0.08, 0.03};
    const char *const labels[3] = {"low", NULL, "high"};
    vdbs_plot_series s = {0};
    s.name = "method";
    s.x = x;
    s.y = y;
    s.labels = labels;
    s.count = 3;
    vdbs_plot_desc d = {0};
    d.width = 420;
    d.height = 300;
    d.title = "round trip";
    d.log_x = d.log_y = 1;
    d.series = &s;
    d.series_count = 1;
    const char *path = test_tmp_path("plot_round_trip.png");
    vdbs_error err;
    if (vdbs_plot_write_png(path, &d, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_image a, b;
    vdbs_plot_layout l;
    render_ok(&d, &a, &l);
    if (vdbs_image_read(path, &b, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(b.width, 420);
    assert_int_equal(b.height, 300);
    const size_t n = (size_t)a.width * a.height * 3;
    size_t differ = 0;
    for (size_t i = 0; i < n; ++i)
        differ += a.rgb[i] != b.rgb[i];
    assert_int_equal(differ, 0);
    vdbs_image_free(&a);
    vdbs_image_free(&b);
    remove(path);
    assert_int_equal(vdbs_plot_write_png(test_tmp_path("plot.bmp"), &d, &err), VDBS_ERR_INPUT);
}

/* A chart like `vdbscatter tradeoff`'s: four methods, the front, the reference's curve. */
static void test_tradeoff_chart(void **state)
{
    (void)state;
    static const char *const names[4] = {"single", "pop", "fld", "svd"};
    static const char *const q[3] = {"low", "medium", "high"};
    /* times 0.5 .. 40 s, errors 0.02 .. 0.5: a biased fast method, three converging ones */
    const double t[4][3] = {{0.5, 1.0, 2.0}, {2.0, 6.0, 20.0}, {1.0, 3.0, 8.0}, {4.0, 12.0, 40.0}};
    const double e[4][3] = {
        {0.30, 0.22, 0.19}, {0.20, 0.08, 0.03}, {0.25, 0.12, 0.07}, {0.12, 0.05, 0.02}};
    /* the front: by time, each point that beats every faster one */
    double ft[12], fe[12];
    int nf = 0;
    for (double last = INFINITY;;) {
        int bm = -1, bi = -1;
        for (int m = 0; m < 4; ++m)
            for (int i = 0; i < 3; ++i)
                if (e[m][i] < last && (bm < 0 || t[m][i] < t[bm][bi] ||
                                       (t[m][i] == t[bm][bi] && e[m][i] < e[bm][bi]))) {
                    bm = m;
                    bi = i;
                }
        if (bm < 0)
            break;
        ft[nf] = t[bm][bi];
        fe[nf++] = last = e[bm][bi];
    }
    assert_int_equal(nf, 9); /* single x3, fld medium, pop medium, fld high, svd medium, ... */
    double rt[8], re[8];
    for (int i = 0; i < 8; ++i) {
        rt[i] = 1.0 * pow(2.0, i * 0.8);
        re[i] = 0.5 / sqrt(rt[i]);
    }
    vdbs_plot_series s[6] = {{0}};
    for (int m = 0; m < 4; ++m) {
        s[m].name = names[m];
        s[m].x = t[m];
        s[m].y = e[m];
        s[m].labels = q;
        s[m].count = 3;
    }
    s[4] = (vdbs_plot_series){
        .name = "Pareto front", .x = ft, .y = fe, .count = nf, .style = VDBS_PLOT_FRONT};
    s[5] = (vdbs_plot_series){
        .name = "reference (MC)", .x = rt, .y = re, .count = 8, .style = VDBS_PLOT_DASHED};
    vdbs_plot_desc d = {0};
    d.title = "error against time";
    d.xlabel = "time (s)";
    d.ylabel = "relative RMSE";
    d.log_x = d.log_y = 1;
    d.series = s;
    d.series_count = 6;
    vdbs_image im;
    vdbs_plot_layout l;
    render_ok(&d, &im, &l);
    static const unsigned colours[4] = {0x1F77B4u, 0xFF7F0Eu, 0x2CA02Cu, 0xD62728u};
    for (int m = 0; m < 4; ++m)
        for (int i = 0; i < 3; ++i) {
            int px, py;
            expect_pixel(&l, t[m][i], e[m][i], &px, &py);
            if (!is_rgb(&im, px, py, colours[m]))
                fail_msg("%s point %d at %d,%d", names[m], i, px, py);
        }
    assert_true(count_rgb(&im, 0x1A1A1Au) > 100); /* the front (and the text) */
    assert_true(count_rgb(&im, 0x7F7F7Fu) > 50);  /* the reference */
    vdbs_error err;
    if (vdbs_image_write(test_tmp_path("plot_tradeoff.png"), &im, 0.0, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_image_free(&im);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_font),
        cmocka_unit_test(test_text_box),
        cmocka_unit_test(test_points_and_axes),
        cmocka_unit_test(test_auto_range),
        cmocka_unit_test(test_unusable_values),
        cmocka_unit_test(test_extremes),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_tradeoff_chart),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
