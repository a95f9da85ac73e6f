/* The viewer's window side: puts a linear float RGB picture on screen (exposure and sRGB
 * encoding in a fragment shader), and reads the window back. */
#ifndef VDBSCATTER_VIEWER_DISPLAY_H
#define VDBSCATTER_VIEWER_DISPLAY_H

#include "vdbscatter/image.h"
#include "vdbscatter/status.h"

typedef struct view_display {
    unsigned program, texture, vertex_array;
    int width, height; /* the texture's */
} view_display;

/* Compiles and links a vertex and a fragment shader; the driver's errors (not its
 * warnings) on one line in err. Needs a current GL context. */
vdbs_status view_gl_program(const char *vertex, const char *fragment, unsigned *program,
                            vdbs_error *err);

/* Needs a current GL 4.3 core context. */
vdbs_status view_display_init(view_display *display, vdbs_error *err);
void view_display_free(view_display *display);
/* Draws `image` (row 0 on top) scaled to the framebuffer, times 2^exposure_ev. */
void view_display_draw(view_display *display, const vdbs_image *image, double exposure_ev,
                       int framebuffer_width, int framebuffer_height);

#endif
