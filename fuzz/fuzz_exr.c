/* The OpenEXR readers (env maps and compare's images) through their contained path. */
#include "fuzz_image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return fuzz_image_readers(data, size, ".exr");
}
