#include "vdbscatter/sphere.h"

#include <math.h>

#include "base/vdbs_math.h"

void vdbs_sphere_directions(int count, double *dirs)
{
    const double golden_angle = VDBS_PI * (3.0 - sqrt(5.0));
    for (int k = 0; k < count; ++k) {
        double z = 1.0 - (2.0 * k + 1.0) / count;
        double r = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = golden_angle * k;
        dirs[3 * k] = r * cos(phi);
        dirs[3 * k + 1] = z;
        dirs[3 * k + 2] = r * sin(phi);
    }
}
