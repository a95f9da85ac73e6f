/* The image readers as both image harnesses drive them: compare's image read and the env-map
 * loader, on one file whose suffix picks the format (.exr: OpenEXR, contained; .hdr: Radiance). */
#ifndef VDBSCATTER_FUZZ_IMAGE_H
#define VDBSCATTER_FUZZ_IMAGE_H

#include "fuzz_util.h"
#include "vdbscatter/envmap.h"
#include "vdbscatter/image.h"

static inline int fuzz_image_readers(const uint8_t *data, size_t size, const char *ext)
{
    const char *path = fuzz_file(data, size, ext);
    vdbs_error err;
    vdbs_image image;
    vdbs_status st = vdbs_image_read(path, &image, &err);
    fuzz_check_error(st, &err, "vdbs_image_read");
    if (st == VDBS_OK) {
        if (image.width <= 0 || image.height <= 0 || !image.rgb) {
            fprintf(stderr, "fuzz: image read returned no pixels\n");
            abort();
        }
        vdbs_image_free(&image);
    }
    vdbs_envmap map;
    st = vdbs_envmap_load(path, 1.0, &map, &err);
    fuzz_check_error(st, &err, "vdbs_envmap_load");
    if (st == VDBS_OK)
        vdbs_envmap_free(&map);
    return 0;
}

#endif
