/* The common subset of C99 and GLSL 4.50 that every shared kernel is written in.
 * Include after PNanoVDB.h (with PNANOVDB_C or PNANOVDB_GLSL defined). In GLSL the
 * buffers named in VS_DATA_PARAM are global SSBOs; in C they are pointer parameters,
 * so kernel bodies index them with the same text. */
#ifndef VS_COMMON_H
#define VS_COMMON_H

#if defined(PNANOVDB_GLSL)

#define VS_FUNC
#define VS_FUNC_HOT
#define VS_PRECISE precise
#define VS_INT(x) int(x)
#define VS_UINT(x) uint(x)
#define VS_FLOAT(x) float(x)
#define vs_vec4 vec4
#define VS_DATA_PARAM(T, name)
#define VS_DATA_ARG(name)
#define VS_DATA_ONLY(T, name)
#define VS_DATA_ONLY_ARG(name)
#define vs_floor floor
#define vs_exp exp
#define vs_ldexp ldexp
#define vs_sqrt sqrt
#define vs_abs abs
#define vs_min min
#define vs_max max
#define vs_pow pow
#define vs_atan2 atan
#define VS_UNUSED(name)
#define vs_uint uint
#define VS_OUT_PARAM(T, name)
#define vs_word_float uintBitsToFloat
#define VS_SIMD

#else

#include <math.h>
#include <stdint.h>
#include <string.h>

#define VS_FUNC static inline
/* For the march's inner loop: gcc stops inlining it once it grew big (split into begin and
 * advance), which cost the per-voxel bake 57%. */
#if defined(__GNUC__)
#define VS_FUNC_HOT static inline __attribute__((always_inline))
#else
#define VS_FUNC_HOT static inline
#endif
#define VS_PRECISE
#define VS_INT(x) ((int)(x))
#define VS_UINT(x) ((unsigned)(x))
#define VS_FLOAT(x) ((float)(x))
typedef struct vs_vec4 {
    float x, y, z, w;
} vs_vec4;
#define VS_DATA_PARAM(T, name) const T *name,
#define VS_DATA_ARG(name) name,
/* A table as a function's only parameter (no trailing comma). */
#define VS_DATA_ONLY(T, name) const T *name
#define VS_DATA_ONLY_ARG(name) name
#define vs_floor floorf
#define vs_exp expf
#define vs_ldexp ldexpf
#define vs_sqrt sqrtf
#define vs_abs fabsf
#define vs_pow powf
#define vs_atan2 atan2f
/* A table parameter a kernel function passes on but does not read (a global in GLSL). */
#define VS_UNUSED(name) (void)(name)
/* Plain comparisons: fminf / fmaxf are library calls (their NaN rules keep gcc from inlining
 * them), in the march's innermost loop. Kernel operands are never NaN. */
static inline float vs_min(float a, float b)
{
    return b < a ? b : a;
}
static inline float vs_max(float a, float b)
{
    return b > a ? b : a;
}
typedef uint32_t vs_uint;
/* An output array: a pointer parameter in C, an SSBO in GLSL. */
#define VS_OUT_PARAM(T, name) T *name,
/* Before a C-path step function that runs a kernel: it is also built for AVX2, the kernel
 * inlined into each build, and the loader picks the one the CPU runs (GNU ifunc; x86-64). Not
 * under AddressSanitizer, whose checks an ifunc resolver can run before. */
#if defined(__GNUC__) && defined(__x86_64__) && defined(__linux__) && !defined(__SANITIZE_ADDRESS__)
#define VS_CPU_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define VS_CPU_CLONES
#endif
/* VS_SIMD: the next loop's trips are independent, so the C path runs them in SIMD lanes
 * (OpenMP's simd: C cannot otherwise be told that the tables, pointers, do not alias); nothing
 * in GLSL, where an invocation is already one lane. A kernel that sums in lanes writes the
 * lanes out itself (vs_svd_dot), so that both paths round alike. */
#if defined(_OPENMP)
#define VS_PRAGMA(text) _Pragma(#text)
#define VS_SIMD VS_PRAGMA(omp simd)
#else
#define VS_SIMD
#endif
/* A float stored as its bits in a table of 32-bit words. */
static inline float vs_word_float(uint32_t w)
{
    float f;
    memcpy(&f, &w, sizeof f);
    return f;
}

#endif

#define VS_PI 3.14159265358979323846f
#define VS_INV_4PI 0.0795774715459476679f
/* VS_PRECISE marks arithmetic that must round as written: the C build does not contract
 * a * b + c into FMA (ISO C mode), and `precise` stops the GLSL compiler from doing it,
 * so that both paths see the same rounding where a march is sensitive to it. */

/* Larger than any ray parameter in a grid (world units); finite so that products stay finite. */
#define VS_T_INFINITE 1.0e30f

VS_FUNC pnanovdb_vec3_t vs_vec3(float x, float y, float z)
{
    pnanovdb_vec3_t v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

VS_FUNC pnanovdb_vec3_t vs_vec3_scale(pnanovdb_vec3_t a, float s)
{
    return vs_vec3(a.x * s, a.y * s, a.z * s);
}

VS_FUNC pnanovdb_vec3_t vs_vec3_madd(pnanovdb_vec3_t a, pnanovdb_vec3_t d, float t)
{
    VS_PRECISE float x = a.x + d.x * t;
    VS_PRECISE float y = a.y + d.y * t;
    VS_PRECISE float z = a.z + d.z * t;
    return vs_vec3(x, y, z);
}

VS_FUNC float vs_vec3_dot(pnanovdb_vec3_t a, pnanovdb_vec3_t b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

/* The unit world direction of a pinhole camera's ray through the centre of pixel (px, py),
 * row 0 on top (camera.h), from the table rows (forward, image height),
 * (right * tan(half fov x), 0) and (up * tan(half fov y), 0) of an image `width` wide. */
VS_FUNC pnanovdb_vec3_t vs_pinhole_direction(vs_vec4 forward, vs_vec4 right, vs_vec4 up,
                                             float width, int px, int py)
{
    VS_PRECISE float sx = 2.0f * (VS_FLOAT(px) + 0.5f) / width - 1.0f;
    VS_PRECISE float sy = 1.0f - 2.0f * (VS_FLOAT(py) + 0.5f) / forward.w;
    pnanovdb_vec3_t d = vs_vec3_madd(vs_vec3_madd(vs_vec3(forward.x, forward.y, forward.z),
                                                  vs_vec3(right.x, right.y, right.z), sx),
                                     vs_vec3(up.x, up.y, up.z), sy);
    return vs_vec3_scale(d, 1.0f / vs_sqrt(vs_vec3_dot(d, d)));
}

VS_FUNC pnanovdb_vec3_t vs_vec3_from_vec4(vs_vec4 v)
{
    return vs_vec3(v.x, v.y, v.z);
}

VS_FUNC pnanovdb_coord_t vs_coord(int x, int y, int z)
{
    pnanovdb_coord_t c;
    c.x = x;
    c.y = y;
    c.z = z;
    return c;
}

/* Optical depth accumulator: double in C; Kahan-compensated float in GLSL (no double
 * on many GPUs), so that long marches of small increments keep their digits. */
#if defined(PNANOVDB_GLSL)
struct vs_accum {
    float sum;
    float carry;
};
VS_FUNC void vs_accum_init(inout vs_accum a)
{
    a.sum = 0.0f;
    a.carry = 0.0f;
}
VS_FUNC void vs_accum_add(inout vs_accum a, float x)
{
    precise float y = x - a.carry;
    precise float t = a.sum + y;
    a.carry = (t - a.sum) - y;
    a.sum = t;
}
VS_FUNC float vs_accum_value(vs_accum a)
{
    return a.sum - a.carry;
}
/* exp(-(sum - carry)) without losing the pair's digits: exp(-x) = 2^-n exp(-r) with
 * n = round(x / ln 2) and r = x - n ln 2 (Cody-Waite: ln2_hi has 15 significant bits, so
 * n * ln2_hi is exact for n < 512), so a float exp only ever sees |r| <= 0.35. Without
 * it, an optical depth of 60 held in one float is already 2e-6 off in transmittance. */
VS_FUNC float vs_accum_exp_neg(vs_accum a)
{
    precise float n = floor(a.sum * 1.44269504f + 0.5f);
    precise float r = ((a.sum - n * 0.693145751953125f) - n * 1.42860677e-6f) - a.carry;
    return ldexp(exp(-r), -int(n));
}
#else
typedef struct vs_accum {
    double sum;
} vs_accum;
VS_FUNC void vs_accum_init(vs_accum *a)
{
    a->sum = 0.0;
}
VS_FUNC void vs_accum_add(vs_accum *a, float x)
{
    a->sum += (double)x;
}
VS_FUNC float vs_accum_value(vs_accum a)
{
    return (float)a.sum;
}
VS_FUNC float vs_accum_exp_neg(vs_accum a)
{
    return (float)exp(-a.sum);
}
#endif

#endif
