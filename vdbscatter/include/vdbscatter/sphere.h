/* Directions spread over the unit sphere: the sky's ordinates and the discrete ordinates'
 * quadrature share them. */
#ifndef VDBSCATTER_SPHERE_H
#define VDBSCATTER_SPHERE_H

#ifdef __cplusplus
extern "C" {
#endif

/* K unit directions spread evenly over the sphere (spherical Fibonacci lattice), equal
 * weights 4 pi / K; `dirs` holds 3 K doubles. */
void vdbs_sphere_directions(int count, double *dirs);

#ifdef __cplusplus
}
#endif

#endif
