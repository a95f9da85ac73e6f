/* The picture a renderer fills, checked against its camera before any work: a wrong one is
 * the caller's mistake. The march (march_session.c) and the reference (reference.c) each
 * keep their own rule and message. */
#ifndef VDBSCATTER_RENDER_IMAGE_CHECK_H
#define VDBSCATTER_RENDER_IMAGE_CHECK_H

#include "vdbscatter/camera.h"
#include "vdbscatter/image.h"
#include "vdbscatter/status.h"

enum {
    RENDER_IMAGE_MARCH,    /* also refuses an empty camera */
    RENDER_IMAGE_REFERENCE /* the reference's message: the size the image must have */
};

static inline vdbs_status render_check_image(const vdbs_camera_frame *frame,
                                             const vdbs_image *image, int rule, vdbs_error *err)
{
    int fits =
        image && image->rgb && image->width == frame->width && image->height == frame->height;
    if (rule == RENDER_IMAGE_REFERENCE) {
        if (!fits)
            return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                                  "reference: the image must be allocated at %dx%d", frame->width,
                                  frame->height);
        return VDBS_OK;
    }
    if (!fits || frame->width < 1 || frame->height < 1)
        return vdbs_error_set(
            err, VDBS_ERR_INTERNAL, "render: image of %dx%d for a camera of %dx%d",
            image ? image->width : 0, image ? image->height : 0, frame->width, frame->height);
    return VDBS_OK;
}

#endif
