#include "vdbscatter/pixels.h"

#include <stdlib.h>
#include <string.h>

/* Bounds that keep EXR byte strides (3 floats per pixel) within int32 and buffer sizes
 * within size_t on 32-bit systems too. */
#define IMAGE_MAX_SIDE (1 << 24)
#define IMAGE_MAX_PIXELS ((long long)1 << 28)

vdbs_status vdbs_image_alloc(vdbs_image *image, int width, int height, int with_se, vdbs_error *err)
{
    memset(image, 0, sizeof *image);
    if (width <= 0 || height <= 0 || width > IMAGE_MAX_SIDE || height > IMAGE_MAX_SIDE ||
        (long long)width * height > IMAGE_MAX_PIXELS)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "image size %dx%d is out of range", width,
                              height);
    size_t n = (size_t)width * (size_t)height * 3;
    image->rgb = calloc(n, sizeof(float));
    if (with_se)
        image->se = calloc(n, sizeof(float));
    if (!image->rgb || (with_se && !image->se)) {
        vdbs_image_free(image);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a %dx%d image", width,
                              height);
    }
    image->width = width;
    image->height = height;
    return VDBS_OK;
}

void vdbs_image_free(vdbs_image *image)
{
    if (!image)
        return;
    free(image->rgb);
    free(image->se);
    memset(image, 0, sizeof *image);
}
