/* Double-precision constants and small helpers shared by the library's C code (private
 * header). The shader headers keep their float constants (VS_PI, VS_INV_4PI in
 * shaders/vs_common.h). */
#ifndef VDBS_MATH_H
#define VDBS_MATH_H

#include <math.h>

#define VDBS_PI 3.14159265358979323846
#define VDBS_INV_4PI (1.0 / (4.0 * VDBS_PI))

/* Two unit vectors completing the unit vector w to an orthonormal basis (u, v, w) (Duff et
 * al. 2017, continuous everywhere). */
static inline void vdbs_ortho_basis(const double w[3], double u[3], double v[3])
{
    double sign = copysign(1.0, w[2]);
    double a = -1.0 / (sign + w[2]);
    double b = w[0] * w[1] * a;
    u[0] = 1.0 + sign * w[0] * w[0] * a;
    u[1] = sign * b;
    u[2] = -sign * w[0];
    v[0] = b;
    v[1] = sign + w[1] * w[1] * a;
    v[2] = -w[1];
}

/* Writes one vec4 entry of a kernel table (shaders/vs_*.h layouts) from doubles. */
static inline void vdbs_table_put(float *entry, double x, double y, double z, double w)
{
    entry[0] = (float)x;
    entry[1] = (float)y;
    entry[2] = (float)z;
    entry[3] = (float)w;
}

#endif
