/* VDBS_API marks what libvdbscatter.so exports: the library is built with hidden visibility,
 * so everything else stays inside it. */
#ifndef VDBSCATTER_EXPORT_H
#define VDBSCATTER_EXPORT_H

#if defined(__GNUC__)
#define VDBS_API __attribute__((visibility("default")))
#else
#define VDBS_API
#endif

#endif
