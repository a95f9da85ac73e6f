/* Images: linear RGB float pixels (row 0 on top), optional per-pixel standard errors;
 * OpenEXR and 8-bit sRGB PNG files; the error metrics of `vdbscatter compare`. */
#ifndef VDBSCATTER_IMAGE_H
#define VDBSCATTER_IMAGE_H

#include "vdbscatter/cancel.h"
#include "vdbscatter/pixels.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes by extension: ".exr" linear float RGB (plus channels se.R, se.G, se.B when se is
 * set), ".png" 8-bit sRGB of rgb * 2^exposure_ev, ".hdr" Radiance RGBE (linear). Written to a
 * temporary name in the same folder and renamed. Errors: unknown extension (VDBS_ERR_INPUT), I/O.
 */
vdbs_status vdbs_image_write(const char *path, const vdbs_image *image, double exposure_ev,
                             vdbs_error *err);
/* vdbs_image_write that also polls cancel (cancel.h; NULL: never) before it starts and once
 * the temporary file is written and synced: when set, the temporary file is removed, the old
 * file at path stays and the result is VDBS_ERR_CANCELLED. */
vdbs_status vdbs_image_write_cancel(const char *path, const vdbs_image *image, double exposure_ev,
                                    const vdbs_cancel *cancel, vdbs_error *err);

/* Reads an EXR, a Radiance HDR (RGBE, linear) or a PNG (decoded from sRGB to linear), by
 * content. An EXR goes through the same C++ Imf reader as environment maps (docs/envmap.md):
 * its data window, any type, layout and compression; channels R, G, B, else Y alone as grey
 * (or the other layouts the map reader takes); se.R, se.G, se.B when all three are present.
 * Errors (VDBS_ERR_INPUT, one line naming the file): missing, unreadable, truncated or
 * foreign file, no R, G, B or Y channels. */
vdbs_status vdbs_image_read(const char *path, vdbs_image *image, vdbs_error *err);

/* A Monte-Carlo image's relative noise, sqrt(mean se^2) / sqrt(mean rgb^2) over pixels and
 * channels: 0 without se or for a black image. */
double vdbs_image_noise(const vdbs_image *image);

typedef enum vdbs_image_kind {
    VDBS_IMAGE_UNKNOWN = 0,
    VDBS_IMAGE_EXR,
    VDBS_IMAGE_HDR,
    VDBS_IMAGE_PNG
} vdbs_image_kind;

/* The format of a file by its first bytes (UNKNOWN for anything else). Errors: cannot open. */
vdbs_status vdbs_image_kind_of(const char *path, vdbs_image_kind *kind, vdbs_error *err);

typedef struct vdbs_image_metrics {
    double relrmse;      /* sqrt(mean((a-b)^2)) / sqrt(mean(b^2)), all pixels and channels */
    double mean_rel;     /* mean of |a-b| / (|b| + 1e-3 mean(b)) */
    double p99_rel;      /* 99th percentile of the same */
    double mean_ratio;   /* sum(a) / sum(b): the sign and size of a bias in brightness */
    long long samples;   /* pixel-channel values used (after masking) */
    int has_se;          /* either image carries se.* channels (a missing one counts as 0) */
    double noise_share;  /* mean(se_a^2 + se_b^2) / mean((a-b)^2) */
    double z_mean;       /* mean of z = (a-b) / sqrt(se_a^2 + se_b^2) */
    double z_rms;        /* rms of z */
    long long z_samples; /* values that entered z (se_a^2 + se_b^2 > 0) */
    double se_image_a;   /* sqrt(mean(se_a^2)) / sqrt(mean(a^2)) when a has se, else 0 */
    double se_image_b;
} vdbs_image_metrics;

/* Metrics of a against the reference b. mask_below > 0 ignores pixels whose reference
 * luminance (0.2126 R + 0.7152 G + 0.0722 B) is below it. Errors: different sizes
 * (VDBS_ERR_INPUT), nothing left after masking.
 * Conventions: mean(b) in the relative-error floor is mean(|b|); p99_rel interpolates
 * linearly between order statistics (numpy's default); a ratio x/0 is 0 when x is 0 and
 * +inf otherwise (relrmse of anything but black against a black reference is +inf); NaN
 * errors count as +inf; z_mean and z_rms are NaN when every se_a^2 + se_b^2 is 0. */
vdbs_status vdbs_image_compare(const vdbs_image *a, const vdbs_image *b, double mask_below,
                               vdbs_image_metrics *metrics, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
