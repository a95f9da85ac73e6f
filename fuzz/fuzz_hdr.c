/* The Radiance HDR readers: compare's images and the env-map loader. */
#include "fuzz_image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return fuzz_image_readers(data, size, ".hdr");
}
