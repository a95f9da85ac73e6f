/* Charts drawn into linear float images (plot.h): a frame with decade or 1-2-5 ticks, series
 * as lines and discs, text in a built-in 5 x 9 bitmap font. Everything is drawn in whole
 * pixels of exact sRGB colours (no anti-aliasing), so that the PNG holds exactly the palette
 * and tests can find a colour at a computed pixel. */
#include "vdbscatter/plot.h"

#include "vdbscatter/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- font ------------------------------------------------------------------------------ */

/* Printable ASCII from ' ' (0x20) to '~' (0x7E): 9 rows each, top first, bit 4 the leftmost
 * of 5 columns. Capitals and digits fill rows 0..6; descenders use rows 7..8. */
static const unsigned char plot_font[95][VDBS_PLOT_GLYPH_H] = {
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, /* space */
    {0x04, 0x04, 0x04, 0x04, 0x04, 0x00, 0x04, 0x00, 0x00}, /* ! */
    {0x0A, 0x0A, 0x0A, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, /* " */
    {0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A, 0x00, 0x00}, /* # */
    {0x04, 0x0F, 0x14, 0x0E, 0x05, 0x1E, 0x04, 0x00, 0x00}, /* $ */
    {0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03, 0x00, 0x00}, /* % */
    {0x0C, 0x12, 0x14, 0x08, 0x15, 0x12, 0x0D, 0x00, 0x00}, /* & */
    {0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, /* ' */
    {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02, 0x00, 0x00}, /* ( */
    {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08, 0x00, 0x00}, /* ) */
    {0x00, 0x04, 0x15, 0x0E, 0x15, 0x04, 0x00, 0x00, 0x00}, /* * */
    {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00, 0x00, 0x00}, /* + */
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08, 0x00}, /* , */
    {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00, 0x00, 0x00}, /* - */
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C, 0x00, 0x00}, /* . */
    {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00, 0x00, 0x00}, /* / */
    {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E, 0x00, 0x00}, /* 0 */
    {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E, 0x00, 0x00}, /* 1 */
    {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F, 0x00, 0x00}, /* 2 */
    {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E, 0x00, 0x00}, /* 3 */
    {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02, 0x00, 0x00}, /* 4 */
    {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E, 0x00, 0x00}, /* 5 */
    {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E, 0x00, 0x00}, /* 6 */
    {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08, 0x00, 0x00}, /* 7 */
    {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E, 0x00, 0x00}, /* 8 */
    {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C, 0x00, 0x00}, /* 9 */
    {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00, 0x00, 0x00}, /* : */
    {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x04, 0x08, 0x00, 0x00}, /* ; */
    {0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02, 0x00, 0x00}, /* < */
    {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00, 0x00, 0x00}, /* = */
    {0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08, 0x00, 0x00}, /* > */
    {0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04, 0x00, 0x00}, /* ? */
    {0x0E, 0x11, 0x01, 0x0D, 0x15, 0x15, 0x0E, 0x00, 0x00}, /* @ */
    {0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11, 0x00, 0x00}, /* A */
    {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E, 0x00, 0x00}, /* B */
    {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E, 0x00, 0x00}, /* C */
    {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C, 0x00, 0x00}, /* D */
    {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F, 0x00, 0x00}, /* E */
    {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10, 0x00, 0x00}, /* F */
    {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F, 0x00, 0x00}, /* G */
    {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11, 0x00, 0x00}, /* H */
    {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E, 0x00, 0x00}, /* I */
    {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C, 0x00, 0x00}, /* J */
    {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11, 0x00, 0x00}, /* K */
    {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F, 0x00, 0x00}, /* L */
    {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11, 0x00, 0x00}, /* M */
    {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11, 0x00, 0x00}, /* N */
    {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E, 0x00, 0x00}, /* O */
    {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10, 0x00, 0x00}, /* P */
    {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D, 0x00, 0x00}, /* Q */
    {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11, 0x00, 0x00}, /* R */
    {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E, 0x00, 0x00}, /* S */
    {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x00, 0x00}, /* T */
    {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E, 0x00, 0x00}, /* U */
    {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04, 0x00, 0x00}, /* V */
    {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A, 0x00, 0x00}, /* W */
    {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11, 0x00, 0x00}, /* X */
    {0x11, 0x11, 0x0A, 0x04, 0x04, 0x04, 0x04, 0x00, 0x00}, /* Y */
    {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F, 0x00, 0x00}, /* Z */
    {0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E, 0x00, 0x00}, /* [ */
    {0x00, 0x10, 0x08, 0x04, 0x02, 0x01, 0x00, 0x00, 0x00}, /* \ */
    {0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E, 0x00, 0x00}, /* ] */
    {0x04, 0x0A, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, /* ^ */
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F, 0x00}, /* _ */
    {0x08, 0x04, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, /* ` */
    {0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F, 0x00, 0x00}, /* a */
    {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E, 0x00, 0x00}, /* b */
    {0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E, 0x00, 0x00}, /* c */
    {0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F, 0x00, 0x00}, /* d */
    {0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E, 0x00, 0x00}, /* e */
    {0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08, 0x00, 0x00}, /* f */
    {0x00, 0x00, 0x0F, 0x11, 0x11, 0x11, 0x0F, 0x01, 0x0E}, /* g */
    {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11, 0x00, 0x00}, /* h */
    {0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E, 0x00, 0x00}, /* i */
    {0x02, 0x00, 0x06, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}, /* j */
    {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12, 0x00, 0x00}, /* k */
    {0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E, 0x00, 0x00}, /* l */
    {0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11, 0x00, 0x00}, /* m */
    {0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11, 0x00, 0x00}, /* n */
    {0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E, 0x00, 0x00}, /* o */
    {0x00, 0x00, 0x1E, 0x11, 0x11, 0x11, 0x1E, 0x10, 0x10}, /* p */
    {0x00, 0x00, 0x0F, 0x11, 0x11, 0x11, 0x0F, 0x01, 0x01}, /* q */
    {0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10, 0x00, 0x00}, /* r */
    {0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E, 0x00, 0x00}, /* s */
    {0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06, 0x00, 0x00}, /* t */
    {0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D, 0x00, 0x00}, /* u */
    {0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04, 0x00, 0x00}, /* v */
    {0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A, 0x00, 0x00}, /* w */
    {0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x00, 0x00}, /* x */
    {0x00, 0x00, 0x11, 0x11, 0x11, 0x11, 0x0F, 0x01, 0x0E}, /* y */
    {0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F, 0x00, 0x00}, /* z */
    {0x02, 0x04, 0x04, 0x08, 0x04, 0x04, 0x02, 0x00, 0x00}, /* { */
    {0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x00, 0x00}, /* | */
    {0x08, 0x04, 0x04, 0x02, 0x04, 0x04, 0x08, 0x00, 0x00}, /* } */
    {0x00, 0x00, 0x08, 0x15, 0x02, 0x00, 0x00, 0x00, 0x00}, /* ~ */
};

const unsigned char *vdbs_plot_glyph(int c)
{
    return c >= ' ' && c <= '~' ? plot_font[c - ' '] : NULL;
}

int vdbs_plot_text_width(const char *text, int scale)
{
    size_t n = text ? strlen(text) : 0;
    if (scale < 1)
        scale = 1;
    if (n == 0)
        return 0;
    if (n > 100000) /* keeps the product within int; nothing that long fits an image */
        n = 100000;
    return (int)(n * VDBS_PLOT_ADVANCE - 1) * scale;
}

/* ---- colours and the canvas ------------------------------------------------------------- */

typedef struct colour {
    float c[3]; /* linear, as stored in the image */
} colour;

/* The inverse of image.c's PNG encoding: the float that it writes back as byte b. */
static float srgb_to_linear(unsigned char b)
{
    double s = b / 255.0;
    return (float)(s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4));
}

static colour rgb_colour(const unsigned char rgb[3])
{
    colour col;
    for (int i = 0; i < 3; ++i)
        col.c[i] = srgb_to_linear(rgb[i]);
    return col;
}

static colour hex_colour(unsigned hex)
{
    const unsigned char rgb[3] = {(unsigned char)(hex >> 16), (unsigned char)(hex >> 8),
                                  (unsigned char)hex};
    return rgb_colour(rgb);
}

#define COLOUR_BACKGROUND 0xFFFFFFu
#define COLOUR_AXES 0x262626u
#define COLOUR_TEXT 0x1A1A1Au
#define COLOUR_GRID_MAJOR 0xE2E2E2u
#define COLOUR_GRID_MINOR 0xF1F1F1u
#define COLOUR_LEGEND_BORDER 0xA0A0A0u
#define COLOUR_NO_DATA 0x909090u
#define COLOUR_DASHED 0x7F7F7Fu
#define COLOUR_FRONT 0x1A1A1Au

/* Tableau's ten colours less grey and olive: told apart on screen and in print. */
static const unsigned plot_palette[] = {0x1F77B4u, 0xFF7F0Eu, 0x2CA02Cu, 0xD62728u,
                                        0x9467BDu, 0x8C564Bu, 0xE377C2u, 0x17BECFu};
#define PALETTE_SIZE ((int)(sizeof plot_palette / sizeof plot_palette[0]))

/* An image and the rectangle (inclusive) that drawing is clipped to. */
typedef struct canvas {
    vdbs_image *im;
    int x0, y0, x1, y1;
} canvas;

static canvas canvas_of(vdbs_image *im)
{
    canvas cv = {im, 0, 0, im->width - 1, im->height - 1};
    return cv;
}

static void put(const canvas *cv, int x, int y, colour col)
{
    if (x < cv->x0 || x > cv->x1 || y < cv->y0 || y > cv->y1)
        return;
    float *p = cv->im->rgb + ((size_t)y * cv->im->width + x) * 3;
    p[0] = col.c[0];
    p[1] = col.c[1];
    p[2] = col.c[2];
}

static void fill_rect(const canvas *cv, int x0, int y0, int x1, int y1, colour col)
{
    x0 = x0 > cv->x0 ? x0 : cv->x0;
    y0 = y0 > cv->y0 ? y0 : cv->y0;
    x1 = x1 < cv->x1 ? x1 : cv->x1;
    y1 = y1 < cv->y1 ? y1 : cv->y1;
    for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
            put(cv, x, y, col);
}

static void outline_rect(const canvas *cv, int x0, int y0, int x1, int y1, colour col)
{
    fill_rect(cv, x0, y0, x1, y0, col);
    fill_rect(cv, x0, y1, x1, y1, col);
    fill_rect(cv, x0, y0, x0, y1, col);
    fill_rect(cv, x1, y0, x1, y1, col);
}

static void text(const canvas *cv, int x, int y, const char *s, int scale, colour col)
{
    if (!s)
        return;
    if (scale < 1)
        scale = 1;
    for (; *s; ++s, x += VDBS_PLOT_ADVANCE * scale) {
        const unsigned char *g = vdbs_plot_glyph((unsigned char)*s);
        if (!g)
            g = vdbs_plot_glyph('?');
        for (int r = 0; r < VDBS_PLOT_GLYPH_H; ++r)
            for (int c = 0; c < VDBS_PLOT_GLYPH_W; ++c)
                if (g[r] & (0x10 >> c))
                    fill_rect(cv, x + c * scale, y + r * scale, x + c * scale + scale - 1,
                              y + r * scale + scale - 1, col);
    }
}

void vdbs_plot_draw_text(vdbs_image *image, int x, int y, const char *s, int scale,
                         const unsigned char rgb[3])
{
    if (!image || !image->rgb || !rgb)
        return;
    canvas cv = canvas_of(image);
    text(&cv, x, y, s, scale, rgb_colour(rgb));
}

/* A filled disc; r*r + r rather than r*r gives rounder small discs. */
static void disc(const canvas *cv, int cx, int cy, int r, colour col)
{
    for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx)
            if (dx * dx + dy * dy <= r * r + r)
                put(cv, cx + dx, cy + dy, col);
}

/* A square pen of side thick with its corners cut from 4 up. */
static void pen(const canvas *cv, int x, int y, int thick, colour col)
{
    const int lo = -(thick - 1) / 2, hi = thick / 2;
    const double c = (lo + hi) * 0.5, r2 = thick * thick * 0.25 + 0.25;
    for (int dy = lo; dy <= hi; ++dy)
        for (int dx = lo; dx <= hi; ++dx)
            if ((dx - c) * (dx - c) + (dy - c) * (dy - c) <= r2)
                put(cv, x + dx, y + dy, col);
}

/* Liang-Barsky: cuts the segment to the box; 0 when nothing of it is inside. */
static int clip_segment(double p[4], double x0, double y0, double x1, double y1)
{
    const double dx = p[2] - p[0], dy = p[3] - p[1];
    if (!isfinite(dx) || !isfinite(dy))
        return 0;
    const double dir[4] = {-dx, dx, -dy, dy};
    const double room[4] = {p[0] - x0, x1 - p[0], p[1] - y0, y1 - p[1]};
    double t0 = 0.0, t1 = 1.0;
    for (int i = 0; i < 4; ++i) {
        if (dir[i] == 0.0) {
            if (room[i] < 0.0)
                return 0;
            continue;
        }
        const double t = room[i] / dir[i];
        if (dir[i] < 0.0) {
            if (t > t1)
                return 0;
            t0 = t > t0 ? t : t0;
        } else {
            if (t < t0)
                return 0;
            t1 = t < t1 ? t : t1;
        }
    }
    const double ax = p[0], ay = p[1];
    p[0] = ax + t0 * dx;
    p[1] = ay + t0 * dy;
    p[2] = ax + t1 * dx;
    p[3] = ay + t1 * dy;
    return 1;
}

#define DASH_ON 8
#define DASH_PERIOD 13

/* A line of pen width thick between pixel centres; *dash (NULL: solid) counts pixels along
 * the way so that a dashed polyline keeps its rhythm across its corners. */
static void line(const canvas *cv, double ax, double ay, double bx, double by, int thick,
                 colour col, int *dash)
{
    double p[4] = {ax, ay, bx, by};
    if (!clip_segment(p, cv->x0 - thick, cv->y0 - thick, cv->x1 + thick, cv->y1 + thick))
        return;
    int x = (int)floor(p[0] + 0.5), y = (int)floor(p[1] + 0.5);
    const int x1 = (int)floor(p[2] + 0.5), y1 = (int)floor(p[3] + 0.5);
    const int dx = abs(x1 - x), dy = -abs(y1 - y), sx = x < x1 ? 1 : -1, sy = y < y1 ? 1 : -1;
    int e = dx + dy;
    for (;;) {
        if (!dash || (*dash)++ % DASH_PERIOD < DASH_ON)
            pen(cv, x, y, thick, col);
        if (x == x1 && y == y1)
            break;
        const int e2 = 2 * e;
        if (e2 >= dy) {
            e += dy;
            x += sx;
        }
        if (e2 <= dx) {
            e += dx;
            y += sy;
        }
    }
}

/* ---- axes ------------------------------------------------------------------------------ */

#define MAX_TICKS 128
#define MAX_DECADES 40 /* beyond: every n-th decade only, no minor ticks */

typedef struct tick {
    double v;
    int major;
    int label;
    char text[24];
} tick;

typedef struct axis {
    double lo, hi;
    int log;
    tick t[MAX_TICKS];
    int n;
    int widest; /* pixels of the widest label of any tick */
} axis;

/* Where v sits between lo (0) and hi (1); 0 for an unusable value. */
static int axis_frac(double v, double lo, double hi, int log_axis, double *t)
{
    if (!isfinite(v) || (log_axis && v <= 0.0))
        return 0;
    *t = log_axis ? (log10(v) - log10(lo)) / (log10(hi) - log10(lo)) : (v - lo) / (hi - lo);
    return isfinite(*t);
}

int vdbs_plot_map(const vdbs_plot_layout *layout, double x, double y, double *px, double *py)
{
    double tx, ty;
    if (!layout || !axis_frac(x, layout->x_min, layout->x_max, layout->log_x, &tx) ||
        !axis_frac(y, layout->y_min, layout->y_max, layout->log_y, &ty))
        return 0;
    const double u = layout->left + tx * (layout->right - layout->left);
    const double v = layout->bottom - ty * (layout->bottom - layout->top);
    if (!isfinite(u) || !isfinite(v))
        return 0;
    if (px)
        *px = u;
    if (py)
        *py = v;
    return 1;
}

/* 1, 2 or 5 times a power of ten, the smallest at least raw. */
static double nice_step(double raw)
{
    const double p = pow(10.0, floor(log10(raw)));
    const double m = raw / p;
    return (m <= 1.0 + 1e-9 ? 1.0 : m <= 2.0 + 1e-9 ? 2.0 : m <= 5.0 + 1e-9 ? 5.0 : 10.0) * p;
}

static double linear_step(double lo, double hi)
{
    return nice_step((hi - lo) / 5.0);
}

/* m x 10^k as "0.02", "5", "100", or "2e-5", "1e6" outside 1e-4 .. 1e5. */
static void format_log(char *s, size_t n, int m, int k)
{
    if (k >= -4 && k <= 5)
        snprintf(s, n, "%.*f", k < 0 ? -k : 0, m * pow(10.0, k));
    else
        snprintf(s, n, "%de%d", m, k);
}

static void format_linear(char *s, size_t n, double v, double step)
{
    if (fabs(v) < step * 1e-6)
        v = 0.0; /* no "-0" */
    const int decimals = step >= 1.0 ? 0 : (int)ceil(-log10(step) - 1e-9);
    if (decimals > 6 || fabs(v) >= 1e7)
        snprintf(s, n, "%g", v);
    else
        snprintf(s, n, "%.*f", decimals, v);
}

static void add_tick(axis *a, double v, int major, const char *label)
{
    if (a->n >= MAX_TICKS)
        return;
    tick *t = &a->t[a->n++];
    t->v = v;
    t->major = major;
    t->label = 0;
    snprintf(t->text, sizeof t->text, "%s", label);
    const int w = vdbs_plot_text_width(t->text, 1);
    a->widest = w > a->widest ? w : a->widest;
}

/* Every tick in range; which get labels is decided once the pixels are known. */
static void make_ticks(axis *a)
{
    char s[24];
    a->n = 0;
    a->widest = 0;
    if (a->log) {
        const int k0 = (int)floor(log10(a->lo) + 1e-9), k1 = (int)ceil(log10(a->hi) - 1e-9);
        const int every = k1 - k0 > MAX_DECADES ? (k1 - k0 + MAX_DECADES - 1) / MAX_DECADES : 1;
        static const int mantissa[3] = {1, 2, 5};
        for (int k = k0; k <= k1; ++k)
            for (int i = 0; i < 3; ++i) {
                if (every > 1 && (i > 0 || ((k % every) + every) % every != 0))
                    continue;
                const double v = mantissa[i] * pow(10.0, k);
                if (v < a->lo * (1.0 - 1e-9) || v > a->hi * (1.0 + 1e-9))
                    continue;
                format_log(s, sizeof s, mantissa[i], k);
                add_tick(a, v, i == 0, s);
            }
    } else {
        const double step = linear_step(a->lo, a->hi);
        const double i0 = ceil(a->lo / step - 1e-9), i1 = floor(a->hi / step + 1e-9);
        for (double i = i0; i <= i1 && a->n < MAX_TICKS; i += 1.0) {
            format_linear(s, sizeof s, i * step, step);
            add_tick(a, i * step, 1, s);
        }
    }
}

/* Labels as dense as room allows: need pixels between label centres, span pixels in all. */
static void choose_labels(axis *a, int span, int need)
{
    if (a->log) {
        const double per_decade = span / (log10(a->hi) - log10(a->lo));
        int every = (int)ceil(need / per_decade);
        every = every < 1 ? 1 : every;
        int labelled = 0;
        for (int i = 0; i < a->n; ++i) {
            const int k = (int)floor(log10(a->t[i].v) + 1e-9);
            a->t[i].label = a->t[i].major && ((k % every) + every) % every == 0;
            labelled += a->t[i].label;
        }
        /* 2x and 5x labels where decades are few and wide, or where they alone are in range
         * (log10(2) and log10(5/2) apart, the closer pair is 0.301 decades). */
        const double decades = log10(a->hi) - log10(a->lo);
        if ((decades <= 2.0 + 1e-9 || labelled < 2) && 0.301 * per_decade >= need)
            for (int i = 0; i < a->n; ++i)
                a->t[i].label = 1;
    } else {
        const double per_tick = a->n > 1 ? span / (double)(a->n - 1) : span;
        int every = (int)ceil(need / per_tick);
        every = every < 1 ? 1 : every;
        const double step = linear_step(a->lo, a->hi);
        for (int i = 0; i < a->n; ++i) {
            const long long j = llround(a->t[i].v / step);
            a->t[i].label = ((j % every) + every) % every == 0;
        }
    }
}

/* ---- the plan: ranges, frame, ticks ------------------------------------------------------ */

#define PAD 10
#define TICK_MAJOR 5
#define TICK_MINOR 3
#define MARKER 3      /* disc radius of VDBS_PLOT_LINE_POINTS, one less for DASHED */
#define CLIP_MARGIN 5 /* discs at the frame's edge stay whole */
#define THICK_LINE 2
#define THICK_FRONT 4
#define LEGEND_ROW 14
#define LEGEND_SAMPLE 26

typedef struct plan {
    int width, height;
    vdbs_plot_layout lay;
    axis ax, ay;
    int any_point;
    int title_scale, title_y, ylabel_y;
} plan;

static int usable_point(const vdbs_plot_desc *d, double x, double y)
{
    return isfinite(x) && isfinite(y) && (!d->log_x || x > 0.0) && (!d->log_y || y > 0.0);
}

static vdbs_status axis_range(const char *name, int log_axis, double set_lo, double set_hi, int any,
                              double lo, double hi, axis *a, vdbs_error *err)
{
    a->log = log_axis;
    if (set_lo != 0.0 || set_hi != 0.0) {
        if (!(set_lo < set_hi) || !isfinite(set_lo) || !isfinite(set_hi) ||
            (log_axis && set_lo <= 0.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "plot: %s range [%g, %g] is empty%s", name,
                                  set_lo, set_hi, log_axis ? " or not positive on a log axis" : "");
        if (!(linear_step(set_lo, set_hi) > 0.0) ||
            (log_axis && !(log10(set_hi) - log10(set_lo) > 0.0)))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "plot: %s range [%g, %g] is too narrow",
                                  name, set_lo, set_hi);
        a->lo = set_lo;
        a->hi = set_hi;
    } else if (!any) {
        a->lo = log_axis ? 1.0 : 0.0;
        a->hi = log_axis ? 10.0 : 1.0;
    } else if (log_axis) {
        int k0 = (int)floor(log10(lo) + 1e-9), k1 = (int)ceil(log10(hi) - 1e-9);
        if (k1 <= k0) { /* one power of ten alone: a decade either side */
            k0 -= 1;
            k1 = k0 + 2;
        }
        a->lo = pow(10.0, k0);
        a->hi = pow(10.0, k1);
    } else {
        if (!(hi - lo > 0.0)) {
            const double pad = lo != 0.0 ? fabs(lo) * 0.5 : 1.0;
            lo -= pad;
            hi += pad;
        }
        const double step = linear_step(lo, hi);
        a->lo = floor(lo / step + 1e-9) * step;
        a->hi = ceil(hi / step - 1e-9) * step;
    }
    make_ticks(a);
    return VDBS_OK;
}

static vdbs_status make_plan(const vdbs_plot_desc *d, plan *p, vdbs_error *err)
{
    if (!d)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "plot: no description");
    if (d->series_count < 0 || (d->series_count > 0 && !d->series))
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "plot: %d series without an array",
                              d->series_count);
    memset(p, 0, sizeof *p);
    p->width = d->width ? d->width : 800;
    p->height = d->height ? d->height : 560;
    if (p->width < 160 || p->height < 120 || p->width > 8192 || p->height > 8192)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "plot: size %dx%d is outside 160x120 .. 8192x8192", p->width,
                              p->height);
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int s = 0; s < d->series_count; ++s) {
        const vdbs_plot_series *se = &d->series[s];
        if (se->count < 0 || (se->count > 0 && (!se->x || !se->y)))
            return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                                  "plot: series %d has %d points and no x or y array", s,
                                  se->count);
        if (se->style < VDBS_PLOT_LINE_POINTS || se->style > VDBS_PLOT_FRONT)
            return vdbs_error_set(err, VDBS_ERR_INTERNAL, "plot: series %d has style %d", s,
                                  se->style);
        for (int i = 0; i < se->count; ++i) {
            if (!usable_point(d, se->x[i], se->y[i]))
                continue;
            p->any_point = 1;
            x0 = fmin(x0, se->x[i]);
            x1 = fmax(x1, se->x[i]);
            y0 = fmin(y0, se->y[i]);
            y1 = fmax(y1, se->y[i]);
        }
    }
    vdbs_status st =
        axis_range("x", d->log_x != 0, d->x_min, d->x_max, p->any_point, x0, x1, &p->ax, err);
    if (st == VDBS_OK)
        st = axis_range("y", d->log_y != 0, d->y_min, d->y_max, p->any_point, y0, y1, &p->ay, err);
    if (st != VDBS_OK)
        return st;

    int top = PAD;
    if (d->title && *d->title) {
        p->title_scale = vdbs_plot_text_width(d->title, 2) <= p->width - 2 * PAD ? 2 : 1;
        p->title_y = top;
        top += VDBS_PLOT_GLYPH_H * p->title_scale + 8;
    }
    if (d->ylabel && *d->ylabel) {
        p->ylabel_y = top;
        top += VDBS_PLOT_GLYPH_H + 6;
    }
    top += 5; /* the top tick label's upper half */
    int bottom = p->height - 1 - PAD - TICK_MAJOR - 4 - VDBS_PLOT_GLYPH_H;
    if (d->xlabel && *d->xlabel)
        bottom -= VDBS_PLOT_GLYPH_H + 6;
    const int left = PAD + p->ay.widest + 4 + TICK_MAJOR;
    const int half_x = p->ax.widest / 2 > 4 ? p->ax.widest / 2 : 4;
    const int right = p->width - 1 - PAD - half_x;
    if (right - left < 60 || bottom - top < 40)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "plot: %dx%d leaves no room for the frame inside the labels",
                              p->width, p->height);
    p->lay = (vdbs_plot_layout){left,     top,      right,    bottom,    p->ax.lo,
                                p->ax.hi, p->ay.lo, p->ay.hi, p->ax.log, p->ay.log};
    choose_labels(&p->ax, right - left, p->ax.widest + 12);
    choose_labels(&p->ay, bottom - top, VDBS_PLOT_GLYPH_H + 10);
    return VDBS_OK;
}

vdbs_status vdbs_plot_layout_of(const vdbs_plot_desc *desc, vdbs_plot_layout *layout,
                                vdbs_error *err)
{
    if (!layout)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "plot: no layout to fill");
    plan *p = malloc(sizeof *p);
    if (!p)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "plot: out of memory");
    vdbs_status st = make_plan(desc, p, err);
    if (st == VDBS_OK)
        *layout = p->lay;
    free(p);
    return st;
}

/* ---- drawing --------------------------------------------------------------------------- */

/* The sRGB colour of series s: its own, or by style (palette in order of the automatic
 * VDBS_PLOT_LINE_POINTS series). */
static void series_rgb(const vdbs_plot_desc *d, int s, unsigned char rgb[3])
{
    const vdbs_plot_series *se = &d->series[s];
    if (se->rgb[0] || se->rgb[1] || se->rgb[2]) {
        memcpy(rgb, se->rgb, 3);
        return;
    }
    unsigned hex = se->style == VDBS_PLOT_DASHED ? COLOUR_DASHED : COLOUR_FRONT;
    if (se->style == VDBS_PLOT_LINE_POINTS) {
        int index = 0;
        for (int i = 0; i < s; ++i) {
            const vdbs_plot_series *o = &d->series[i];
            index += o->style == VDBS_PLOT_LINE_POINTS && !(o->rgb[0] || o->rgb[1] || o->rgb[2]);
        }
        hex = plot_palette[index % PALETTE_SIZE];
    }
    rgb[0] = (unsigned char)(hex >> 16);
    rgb[1] = (unsigned char)(hex >> 8);
    rgb[2] = (unsigned char)hex;
}

static colour series_colour(const vdbs_plot_desc *d, int s)
{
    unsigned char rgb[3];
    series_rgb(d, s, rgb);
    return rgb_colour(rgb);
}

/* The series colour at 70%: point labels that read as the series yet stay legible. */
static colour label_colour(const vdbs_plot_desc *d, int s)
{
    unsigned char rgb[3];
    series_rgb(d, s, rgb);
    for (int i = 0; i < 3; ++i)
        rgb[i] = (unsigned char)(rgb[i] * 7 / 10);
    return rgb_colour(rgb);
}

/* The pixel of a usable point, or 0 for one so far out (explicit ranges) that it would
 * not fit an int: nothing of its disc or label could show anyway. */
static int point_pixel(const plan *p, double x, double y, int *px, int *py)
{
    double u, v;
    if (!vdbs_plot_map(&p->lay, x, y, &u, &v) || fabs(u) > 1e6 || fabs(v) > 1e6)
        return 0;
    *px = (int)floor(u + 0.5);
    *py = (int)floor(v + 0.5);
    return 1;
}

static void draw_series_line(const canvas *cv, const plan *p, const vdbs_plot_series *se,
                             colour col)
{
    const int thick = se->style == VDBS_PLOT_FRONT ? THICK_FRONT : THICK_LINE;
    int dash = 0, have = 0;
    double lx = 0.0, ly = 0.0;
    for (int i = 0; i < se->count; ++i) {
        double px, py;
        if (!vdbs_plot_map(&p->lay, se->x[i], se->y[i], &px, &py))
            continue;
        if (have)
            line(cv, lx, ly, px, py, thick, col, se->style == VDBS_PLOT_DASHED ? &dash : NULL);
        lx = px;
        ly = py;
        have = 1;
    }
}

static void marker(const canvas *cv, int style, int x, int y, colour col)
{
    const int r = style == VDBS_PLOT_DASHED ? MARKER - 1 : MARKER;
    disc(cv, x, y, r + 1, hex_colour(COLOUR_BACKGROUND)); /* a ring that parts crossings */
    disc(cv, x, y, r, col);
}

static void draw_series_points(const canvas *cv, const plan *p, const vdbs_plot_series *se,
                               colour col)
{
    if (se->style == VDBS_PLOT_FRONT)
        return;
    for (int i = 0; i < se->count; ++i) {
        int x, y;
        if (point_pixel(p, se->x[i], se->y[i], &x, &y))
            marker(cv, se->style, x, y, col);
    }
}

static void draw_point_labels(const canvas *cv, const plan *p, const vdbs_plot_series *se,
                              colour col)
{
    if (!se->labels)
        return;
    for (int i = 0; i < se->count; ++i) {
        int x, y;
        if (!se->labels[i] || !*se->labels[i] || !point_pixel(p, se->x[i], se->y[i], &x, &y))
            continue;
        if (x < p->lay.left - CLIP_MARGIN || x > p->lay.right + CLIP_MARGIN ||
            y < p->lay.top - CLIP_MARGIN || y > p->lay.bottom + CLIP_MARGIN)
            continue; /* its disc is clipped away: no label out in the margins */
        const int w = vdbs_plot_text_width(se->labels[i], 1);
        int tx = x + MARKER + 3, ty = y - MARKER - VDBS_PLOT_GLYPH_H + 1;
        if (tx + w > p->lay.right - 2)
            tx = x - MARKER - 3 - w;
        if (ty < p->lay.top + 2)
            ty = y + MARKER + 2;
        text(cv, tx, ty, se->labels[i], 1, col);
    }
}

static void draw_axes(const canvas *cv, const plan *p, const vdbs_plot_desc *d)
{
    const vdbs_plot_layout *l = &p->lay;
    const colour axes = hex_colour(COLOUR_AXES), ink = hex_colour(COLOUR_TEXT);
    outline_rect(cv, l->left, l->top, l->right, l->bottom, axes);
    for (int i = 0; i < p->ax.n; ++i) {
        const tick *t = &p->ax.t[i];
        double px;
        if (!vdbs_plot_map(l, t->v, l->y_min, &px, NULL))
            continue;
        const int x = (int)floor(px + 0.5);
        fill_rect(cv, x, l->bottom + 1, x, l->bottom + (t->major ? TICK_MAJOR : TICK_MINOR), axes);
        if (t->label)
            text(cv, x - vdbs_plot_text_width(t->text, 1) / 2, l->bottom + TICK_MAJOR + 4, t->text,
                 1, ink);
    }
    for (int i = 0; i < p->ay.n; ++i) {
        const tick *t = &p->ay.t[i];
        double py;
        if (!vdbs_plot_map(l, l->x_min, t->v, NULL, &py))
            continue;
        const int y = (int)floor(py + 0.5);
        fill_rect(cv, l->left - (t->major ? TICK_MAJOR : TICK_MINOR), y, l->left - 1, y, axes);
        if (t->label) /* cap height 7: row 3 on the tick */
            text(cv, l->left - TICK_MAJOR - 4 - vdbs_plot_text_width(t->text, 1), y - 3, t->text, 1,
                 ink);
    }
    if (d->xlabel && *d->xlabel)
        text(cv, (l->left + l->right) / 2 - vdbs_plot_text_width(d->xlabel, 1) / 2,
             l->bottom + TICK_MAJOR + 4 + VDBS_PLOT_GLYPH_H + 6, d->xlabel, 1, ink);
    if (d->ylabel && *d->ylabel)
        text(cv, PAD, p->ylabel_y, d->ylabel, 1, ink);
    if (d->title && *d->title) {
        const int w = vdbs_plot_text_width(d->title, p->title_scale);
        int x = (l->left + l->right) / 2 - w / 2;
        x = x + w > p->width - PAD ? p->width - PAD - w : x;
        text(cv, x < PAD ? PAD : x, p->title_y, d->title, p->title_scale, ink);
    }
}

static void draw_grid(const canvas *cv, const plan *p)
{
    const vdbs_plot_layout *l = &p->lay;
    const colour major = hex_colour(COLOUR_GRID_MAJOR), minor = hex_colour(COLOUR_GRID_MINOR);
    for (int i = 0; i < p->ax.n; ++i) {
        double px;
        if (vdbs_plot_map(l, p->ax.t[i].v, l->y_min, &px, NULL)) {
            const int x = (int)floor(px + 0.5);
            fill_rect(cv, x, l->top + 1, x, l->bottom - 1, p->ax.t[i].major ? major : minor);
        }
    }
    for (int i = 0; i < p->ay.n; ++i) {
        double py;
        if (vdbs_plot_map(l, l->x_min, p->ay.t[i].v, NULL, &py)) {
            const int y = (int)floor(py + 0.5);
            fill_rect(cv, l->left + 1, y, l->right - 1, y, p->ay.t[i].major ? major : minor);
        }
    }
}

static void draw_legend(const canvas *cv, const plan *p, const vdbs_plot_desc *d)
{
    int n = 0, widest = 0;
    for (int s = 0; s < d->series_count; ++s)
        if (d->series[s].name) {
            const int w = vdbs_plot_text_width(d->series[s].name, 1);
            widest = w > widest ? w : widest;
            ++n;
        }
    if (n == 0 || d->legend == VDBS_PLOT_LEGEND_NONE)
        return;
    const vdbs_plot_layout *l = &p->lay;
    const int bw = 8 + LEGEND_SAMPLE + 6 + widest + 8, bh = 5 + n * LEGEND_ROW + 3;
    const int at_left =
        d->legend == VDBS_PLOT_LEGEND_TOP_LEFT || d->legend == VDBS_PLOT_LEGEND_BOTTOM_LEFT;
    const int at_bottom =
        d->legend == VDBS_PLOT_LEGEND_BOTTOM_LEFT || d->legend == VDBS_PLOT_LEGEND_BOTTOM_RIGHT;
    const int x0 = at_left ? l->left + 8 : l->right - 8 - bw;
    const int y0 = at_bottom ? l->bottom - 8 - bh : l->top + 8;
    fill_rect(cv, x0, y0, x0 + bw - 1, y0 + bh - 1, hex_colour(COLOUR_BACKGROUND));
    outline_rect(cv, x0, y0, x0 + bw - 1, y0 + bh - 1, hex_colour(COLOUR_LEGEND_BORDER));
    int row = 0;
    for (int s = 0; s < d->series_count; ++s) {
        const vdbs_plot_series *se = &d->series[s];
        if (!se->name)
            continue;
        const colour col = series_colour(d, s);
        const int y = y0 + 5 + row * LEGEND_ROW + 6, xs = x0 + 8;
        int dash = 0;
        line(cv, xs, y, xs + LEGEND_SAMPLE - 1, y,
             se->style == VDBS_PLOT_FRONT ? THICK_FRONT : THICK_LINE, col,
             se->style == VDBS_PLOT_DASHED ? &dash : NULL);
        if (se->style != VDBS_PLOT_FRONT)
            marker(cv, se->style, xs + LEGEND_SAMPLE / 2, y, col);
        text(cv, xs + LEGEND_SAMPLE + 6, y - 3, se->name, 1, hex_colour(COLOUR_TEXT));
        ++row;
    }
}

vdbs_status vdbs_plot_render(const vdbs_plot_desc *desc, vdbs_image *image, vdbs_error *err)
{
    if (!image)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "plot: no image to fill");
    memset(image, 0, sizeof *image);
    plan *p = malloc(sizeof *p);
    if (!p)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "plot: out of memory");
    vdbs_status st = make_plan(desc, p, err);
    if (st == VDBS_OK)
        st = vdbs_image_alloc(image, p->width, p->height, 0, err);
    if (st != VDBS_OK) {
        free(p);
        return st;
    }
    const vdbs_plot_desc *d = desc;
    canvas all = canvas_of(image);
    fill_rect(&all, 0, 0, p->width - 1, p->height - 1, hex_colour(COLOUR_BACKGROUND));
    draw_grid(&all, p);

    canvas data = all;
    data.x0 = p->lay.left - CLIP_MARGIN;
    data.y0 = p->lay.top - CLIP_MARGIN;
    data.x1 = p->lay.right + CLIP_MARGIN;
    data.y1 = p->lay.bottom + CLIP_MARGIN;
    /* Data: lines, then the front over them (where it runs along a method's line it stays
     * visible), then every disc, labels on top. */
    for (int s = 0; s < d->series_count; ++s)
        if (d->series[s].style != VDBS_PLOT_FRONT)
            draw_series_line(&data, p, &d->series[s], series_colour(d, s));
    for (int s = 0; s < d->series_count; ++s)
        if (d->series[s].style == VDBS_PLOT_FRONT)
            draw_series_line(&data, p, &d->series[s], series_colour(d, s));
    for (int s = 0; s < d->series_count; ++s)
        draw_series_points(&data, p, &d->series[s], series_colour(d, s));
    draw_axes(&all, p, d);
    for (int s = 0; s < d->series_count; ++s)
        draw_point_labels(&all, p, &d->series[s], label_colour(d, s));
    if (!p->any_point) {
        static const char none[] = "no data";
        text(&all, (p->lay.left + p->lay.right) / 2 - vdbs_plot_text_width(none, 2) / 2,
             (p->lay.top + p->lay.bottom) / 2 - VDBS_PLOT_GLYPH_H, none, 2,
             hex_colour(COLOUR_NO_DATA));
    }
    draw_legend(&all, p, d);
    free(p);
    return VDBS_OK;
}

vdbs_status vdbs_plot_write_png(const char *path, const vdbs_plot_desc *desc, vdbs_error *err)
{
    if (!path)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "plot: no output path");
    vdbs_image image;
    vdbs_status st = vdbs_plot_render(desc, &image, err);
    if (st == VDBS_OK)
        st = vdbs_image_write(path, &image, 0.0, err);
    vdbs_image_free(&image);
    return st;
}
