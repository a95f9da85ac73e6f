/* Double-precision constants and small helpers shared by the library's C code (private
 * header). The shader headers keep their float constants (VS_PI, VS_INV_4PI in
 * shaders/vs_common.h). */
#ifndef VDBS_MATH_H
#define VDBS_MATH_H

#define VDBS_PI 3.14159265358979323846

/* Writes one vec4 entry of a kernel table (shaders/vs_*.h layouts) from doubles. */
static inline void vdbs_table_put(float *entry, double x, double y, double z, double w)
{
    entry[0] = (float)x;
    entry[1] = (float)y;
    entry[2] = (float)z;
    entry[3] = (float)w;
}

#endif
