/* Constants shared by the library's C sources (the kernels have theirs in vs_common.h). */
#ifndef VDBSCATTER_VDBS_MATH_H
#define VDBSCATTER_VDBS_MATH_H

#define VDBS_PI 3.14159265358979323846

#endif
