/* Double-precision constants shared by the library's C code (private header). The shader
 * headers keep their float constants (VS_PI, VS_INV_4PI in shaders/vs_common.h). */
#ifndef VDBS_MATH_H
#define VDBS_MATH_H

/* Spelled exactly like the copies that single.c and render.c still define, so that a
 * file seeing both gets an identical (allowed) redefinition until those copies go. */
#define VDBS_PI 3.14159265358979323846

#endif
