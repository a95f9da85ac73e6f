/* Minimal charts without a plotting library: series of points on linear or log axes, drawn
 * into an image with a built-in bitmap font, for `vdbscatter tradeoff` (error against time,
 * one series per method, the Pareto front, the reference's own curve). */
#ifndef VDBSCATTER_PLOT_H
#define VDBSCATTER_PLOT_H

#include "vdbscatter/pixels.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbs_plot_style {
    VDBS_PLOT_LINE_POINTS = 0, /* points (filled discs) joined by lines; auto colour: palette */
    VDBS_PLOT_DASHED,          /* dashed line, small discs; auto colour: grey */
    VDBS_PLOT_FRONT            /* thick line over other lines, under discs; auto: near-black */
} vdbs_plot_style;

typedef enum vdbs_plot_legend {
    VDBS_PLOT_LEGEND_TOP_RIGHT = 0, /* inside the frame; empty on error-against-time charts */
    VDBS_PLOT_LEGEND_TOP_LEFT,
    VDBS_PLOT_LEGEND_BOTTOM_LEFT,
    VDBS_PLOT_LEGEND_BOTTOM_RIGHT,
    VDBS_PLOT_LEGEND_NONE
} vdbs_plot_legend;

typedef struct vdbs_plot_series {
    const char *name;          /* legend entry; NULL: not in the legend */
    const double *x, *y;       /* count values each */
    const char *const *labels; /* NULL, or count strings (NULL entries: none) beside the points */
    int count;
    unsigned char rgb[3]; /* sRGB; 0,0,0: automatic by style (use 1,1,1 for black) */
    int style;            /* vdbs_plot_style */
} vdbs_plot_series;

typedef struct vdbs_plot_desc {
    int width, height;                   /* 0: 800 x 560 */
    const char *title, *xlabel, *ylabel; /* NULL: none; the y label sits above the frame */
    int log_x, log_y;                    /* nonzero: logarithmic axis */
    /* Axis ranges; both 0: automatic over the usable points, widened to whole decades on a
     * log axis and to whole tick steps (1, 2 or 5 x 10^k) on a linear one. */
    double x_min, x_max, y_min, y_max;
    int legend; /* vdbs_plot_legend */
    const vdbs_plot_series *series;
    int series_count;
} vdbs_plot_desc;

/* Where the data go: the frame's edge pixels (the axis lines are drawn on these rows and
 * columns) and the ranges they span. */
typedef struct vdbs_plot_layout {
    int left, top, right, bottom;
    double x_min, x_max, y_min, y_max;
    int log_x, log_y;
} vdbs_plot_layout;

/* The layout vdbs_plot_render uses for desc. Errors as vdbs_plot_render. */
vdbs_status vdbs_plot_layout_of(const vdbs_plot_desc *desc, vdbs_plot_layout *layout,
                                vdbs_error *err);

/* The pixel of a data point: x_min maps to left and x_max to right, y_min to bottom and y_max
 * to top, linearly in the value or in log10 of it; a point is drawn centred on
 * (floor(px + 0.5), floor(py + 0.5)). Returns 0 (and leaves px, py) for an unusable value:
 * not finite, or not positive on a log axis. */
int vdbs_plot_map(const vdbs_plot_layout *layout, double x, double y, double *px, double *py);

/* Draws the chart into a new image (vdbs_image_alloc; free with vdbs_image_free) of linear
 * floats that vdbs_image_write turns, at exposure 0, into exactly the chart's sRGB colours.
 * A point is used when both its values are usable (see vdbs_plot_map); unusable points are
 * skipped and lines join the usable ones in the order given. With no usable point at all (or no
 * series) the chart is drawn empty over x and y in [1, 10] (log) or [0, 1] (linear), with the
 * legend, and the result is VDBS_OK: the caller decides whether an empty chart is an error. Point
 * labels may overlap each other; nothing moves them apart.
 * Errors: VDBS_ERR_INTERNAL for a NULL desc or image, a negative count, a series without
 * x or y or of an unknown style; VDBS_ERR_INPUT for a size outside 160 x 120 .. 8192 x 8192 or too
 * small for the labels, or an explicit range that is empty (or not positive on a log axis). */
vdbs_status vdbs_plot_render(const vdbs_plot_desc *desc, vdbs_image *image, vdbs_error *err);

/* vdbs_plot_render to a PNG (or any vdbs_image_write extension) at path. */
vdbs_status vdbs_plot_write_png(const char *path, const vdbs_plot_desc *desc, vdbs_error *err);

/* The built-in fixed-width font: printable ASCII, 5 x 9 pixel glyphs (rows 0..6 above the
 * baseline, 7..8 for descenders) in a 6-pixel advance. */
#define VDBS_PLOT_GLYPH_W 5
#define VDBS_PLOT_GLYPH_H 9
#define VDBS_PLOT_ADVANCE 6

/* The 9 rows of character c, top first, bit 4 the leftmost column; NULL outside ' '..'~'. */
const unsigned char *vdbs_plot_glyph(int c);

/* Width in pixels of text drawn at scale (< 1 counts as 1): no trailing spacing; 0 for "". */
int vdbs_plot_text_width(const char *text, int scale);

/* Draws text with its first glyph's top-left corner at (x, y), each font pixel a scale x
 * scale square of the sRGB colour rgb, clipped to the image; characters outside ' '..'~'
 * draw as '?'. */
void vdbs_plot_draw_text(vdbs_image *image, int x, int y, const char *text, int scale,
                         const unsigned char rgb[3]);

#ifdef __cplusplus
}
#endif

#endif
