/* An image's pixels in memory: linear RGB floats and optional standard errors. Kept apart
 * from the files and metrics of image.h so that the OpenEXR reader (io/exrmap.cpp), which
 * image.c calls, fills one without calling back into image.c. */
#ifndef VDBSCATTER_PIXELS_H
#define VDBSCATTER_PIXELS_H

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_image {
    int width;
    int height;
    float *rgb; /* 3 * width * height, linear, row-major, row 0 on top */
    float *se;  /* NULL, or 3 * width * height standard errors of the pixel estimates */
} vdbs_image;

vdbs_status vdbs_image_alloc(vdbs_image *image, int width, int height, int with_se,
                             vdbs_error *err);
void vdbs_image_free(vdbs_image *image);

#ifdef __cplusplus
}
#endif

#endif
