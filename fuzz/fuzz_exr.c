/* The OpenEXR readers (env maps and compare's images) through their contained path. */
#include "fuzz_util.h"
#include "vdbscatter/envmap.h"
#include "vdbscatter/image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file(data, size, ".exr");
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
