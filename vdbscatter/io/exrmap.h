/* OpenEXR files read through the C++ Imf library (exrmap.cpp, a small bridge: no exception
 * crosses into C): environment maps, and every EXR image vdbs_image_read meets. See
 * docs/envmap.md. */
#ifndef VDBSCATTER_EXRMAP_H
#define VDBSCATTER_EXRMAP_H

#include "vdbscatter/pixels.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads the first part of an OpenEXR file as linear RGB floats (image allocated here): the
 * pixels of its data window (the display window is ignored), level 0 of a tiled,
 * mipmapped or ripmapped file, any compression, half, float or uint channels converted to
 * float. Channels R, G, B (A and others ignored); else Y alone as grey (R = G = B = Y), or
 * Y, RY, BY (luminance/chroma) converted to RGB; else the R, G, B of the one layer that has
 * all three (e.g. diffuse.R, diffuse.G, diffuse.B). Errors (VDBS_ERR_INPUT, one line naming
 * the file): unreadable, corrupt or truncated file, deep data, no usable channels (the
 * channels found are listed), subsampled colour channels; VDBS_ERR_NOMEM. */
vdbs_status vdbs_exrmap_read(const char *path, vdbs_image *image, vdbs_error *err);

/* vdbs_exrmap_read plus the per-pixel standard errors of `render --mode reference`: when the
 * file has all of se.R, se.G and se.B (full resolution, any type), image->se holds them,
 * else image->se is NULL. The reader of vdbs_image_read for OpenEXR files (compare). Errors:
 * those of vdbs_exrmap_read, and a subsampled se channel (VDBS_ERR_INPUT). */
vdbs_status vdbs_exrimage_read(const char *path, vdbs_image *image, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
