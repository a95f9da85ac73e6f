/* Double-precision constants shared by the library's C code (private header). The shader
 * headers keep their float constants (VS_PI, VS_INV_4PI in shaders/vs_common.h). */
#ifndef VDBS_MATH_H
#define VDBS_MATH_H

#define VDBS_PI 3.14159265358979323846

#endif
