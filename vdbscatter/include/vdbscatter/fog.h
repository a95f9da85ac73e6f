/* Analytic single scattering in a homogeneous fog (Biri 2006, papers/single-scattering.md):
 * the tables that the shared kernels of shaders/vs_fog.h read (a point light's in-scattering
 * along lit spans of view rays, a sun's in a fog box, and the fog's light on Lambertian
 * surfaces), and a brute-force quadrature of Eq. 3 as the oracle.
 *
 * Conventions as in docs/design.md: sigma_t per world unit, sigma_s = albedo sigma_t, HG phase of
 * the cosine between propagation directions; a view ray is o + s d (d unit), its radiance
 * travels along -d toward the camera. */
#ifndef VDBSCATTER_FOG_H
#define VDBSCATTER_FOG_H

#include <stddef.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Table shape defaults (see docs/fog.md for how they were chosen). The Gamma table's
 * lambda = sigma_t h runs over [0, lambda_max]; beyond it the last row is used, and a ray
 * passing that far from the light carries less than exp(-lambda_max) of the light's
 * in-scattering per unit h. */
#define VDBS_FOG_DEFAULT_N_LAMBDA 256
#define VDBS_FOG_DEFAULT_N_GAMMA 256
#define VDBS_FOG_DEFAULT_LAMBDA_MAX 32.0
#define VDBS_FOG_DEFAULT_LAMBERT_N_LAMBDA 128
#define VDBS_FOG_DEFAULT_LAMBERT_N_COS 65
#define VDBS_FOG_DEFAULT_LAMBERT_LAMBDA_MAX 32.0
#define VDBS_FOG_MIN_TABLE 8
#define VDBS_FOG_MAX_TABLE 4096

/* Zero-initialise and set what you need. sigma_t (>= 0, per world unit), albedo (in [0, 1])
 * and g (|g| <= 0.999) are taken as they are (0 is a valid sigma_t, albedo and g); the table
 * shape fields use 0 for their defaults. */
typedef struct vdbs_fog_desc {
    double sigma_t;
    double albedo;
    double g;
    int n_lambda;              /* Gamma table rows; 0 = VDBS_FOG_DEFAULT_N_LAMBDA */
    int n_gamma;               /* Gamma table columns; 0 = VDBS_FOG_DEFAULT_N_GAMMA */
    double lambda_max;         /* 0 = VDBS_FOG_DEFAULT_LAMBDA_MAX */
    int lambert_n_lambda;      /* 0 = VDBS_FOG_DEFAULT_LAMBERT_N_LAMBDA */
    int lambert_n_cos;         /* 0 = VDBS_FOG_DEFAULT_LAMBERT_N_COS */
    double lambert_lambda_max; /* 0 = VDBS_FOG_DEFAULT_LAMBERT_LAMBDA_MAX */
} vdbs_fog_desc;

typedef struct vdbs_fog {
    vdbs_fog_desc desc; /* with the defaults filled in */
    float *table;       /* the kernels' table (shaders/vs_fog.h layout); owned */
    size_t table_floats;
} vdbs_fog;

/* Builds the tables for desc's g (they depend on g only; sigma_t and albedo are copied into
 * the header, see vdbs_fog_set_medium). Errors: sigma_t negative or not finite, albedo
 * outside [0, 1], |g| > 0.999 or NaN, table sizes outside [VDBS_FOG_MIN_TABLE,
 * VDBS_FOG_MAX_TABLE], lambda ranges not in (0, 80] (VDBS_ERR_INPUT); out of memory. On
 * error the fog holds nothing to free. */
vdbs_status vdbs_fog_build(const vdbs_fog_desc *desc, vdbs_fog *fog, vdbs_error *err);

void vdbs_fog_free(vdbs_fog *fog);

/* Changes sigma_t and albedo in a built table without rebuilding it (the tables do not
 * depend on them). Same checks as vdbs_fog_build. */
vdbs_status vdbs_fog_set_medium(vdbs_fog *fog, double sigma_t, double albedo, vdbs_error *err);

/* The shared kernels on the C path (float arithmetic, the shaders' text). d must be unit.
 * Point light of intensity I (W/sr) at `light`; lit span [s0, s1] of the ray o + s d that
 * enters the fog at s_enter <= s0 (see vs_fog_point_span). */
float vdbs_fog_point_span(const vdbs_fog *fog, const double o[3], const double d[3],
                          const double light[3], double intensity, double s_enter, double s0,
                          double s1);

/* Sun travelling along sun_dir (unit) with irradiance E, fog box [lo, hi]; the span lies in
 * the box (see vs_fog_sun_span). */
float vdbs_fog_sun_span(const vdbs_fog *fog, const double o[3], const double d[3],
                        const double sun_dir[3], double irradiance, const double lo[3],
                        const double hi[3], double s_enter, double s0, double s1);

/* Radiance leaving a Lambertian point (diffuse reflectance rho) at distance l from a point
 * light of intensity I, cos_phi_n between its normal and the direction to the light (see
 * vs_fog_surface_indirect). */
float vdbs_fog_surface_indirect(const vdbs_fog *fog, double l, double cos_phi_n, double intensity,
                                double reflectance);

/* Biri's Gamma(lambda, gamma) (Eq. 6) from the table, gamma in [-pi/2, pi/2]. */
float vdbs_fog_gamma(const vdbs_fog *fog, double lambda, double gamma);

/* The oracle: Eq. 3 integrated directly in double, composite 8-point Gauss-Legendre in s
 * with panels no wider than a quarter of the distance to the light (plus h) nor than
 * 1/(4 sigma_t), cut at the light's foot point. Same arguments as vdbs_fog_point_span with
 * the medium from desc; s1 may be infinite (cut where the view transmittance is e^-50). */
double vdbs_fog_point_march(const vdbs_fog_desc *desc, const double o[3], const double d[3],
                            const double light[3], double intensity, double s_enter, double s0,
                            double s1);

#ifdef __cplusplus
}
#endif

#endif
