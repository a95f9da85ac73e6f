#include "vdbscatter/quality.h"

#include <string.h>

static const vdbs_quality qualities[VDBS_QUALITY_COUNT] = {
    {"low", 16, 1.0f, 1},
    {"medium", 64, 0.5f, 1},
    {"high", 256, 0.25f, 2},
    {"ultra", 1024, 0.125f, 2},
};

const vdbs_quality *vdbs_quality_find(const char *name)
{
    for (int q = 0; name && q < VDBS_QUALITY_COUNT; ++q)
        if (strcmp(name, qualities[q].name) == 0)
            return &qualities[q];
    return NULL;
}

const vdbs_quality *vdbs_quality_list(int *count)
{
    *count = VDBS_QUALITY_COUNT;
    return qualities;
}

int vdbs_quality_level(const char *name)
{
    const vdbs_quality *q = vdbs_quality_find(name);
    return q ? (int)(q - qualities) : 1;
}

int vdbs_quality_sky_directions(const char *name)
{
    const vdbs_quality *q = vdbs_quality_find(name);
    return q ? q->sky_directions : 0;
}
