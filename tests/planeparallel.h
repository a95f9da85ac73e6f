/* Adding-doubling for a plane-parallel homogeneous slab under a normal beam: the oracle of the
 * slab tests (the Monte-Carlo reference's in test_stat_reference, the solver grids' in
 * test_slab_grid). Directions are PP_NQ Gauss-Legendre cosines per hemisphere
 * (test_gauss_legendre(PP_NQ, 0, 1)); planeparallel.c says how it is built and how good. */
#ifndef VDBS_PLANEPARALLEL_H
#define VDBS_PLANEPARALLEL_H

#define PP_NQ 64

/* Henyey-Greenstein per steradian at the cosine mu of the scattering angle. */
double pp_hg(double g, double mu);

/* Fractions of a normal beam of irradiance 1 reflected and transmitted (direct included) by a
 * slab of optical thickness tau; r_rad and t_rad (NULL or PP_NQ values) receive the diffusely
 * reflected and transmitted radiance at the nodes' cosines; n_extra further cosines mu_extra
 * in (0, 1] ride along (r_extra, t_extra: NULL or n_extra values), the solver's own answer in
 * those directions, not an interpolation. */
void pp_adding_doubling_dirs(double tau, double albedo, double g, double *refl, double *trans,
                             double *r_rad, double *t_rad, int n_extra, const double *mu_extra,
                             double *r_extra, double *t_extra);
void pp_adding_doubling(double tau, double albedo, double g, double *refl, double *trans,
                        double *r_rad, double *t_rad);

/* The radiance a slab of optical thickness tau under a normal beam of irradiance 1 reflects
 * along each cosine mu_view (single and multiple scattering), by discrete ordinates inside the
 * slab: exact with the full angular field; lobe with the multiple scattering rebuilt from its
 * direction average and first moment, the lit VDB's ms and ms_l1, as its renderers do. The
 * difference is what the lit VDB's format cannot carry, whatever the solver. */
void pp_moments_reflection(double tau, double albedo, double g, int n_view, const double *mu_view,
                           double *exact, double *lobe);

#endif
