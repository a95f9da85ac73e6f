/* One Jacobi step of the 7-point Laplacian, shared by C and GLSL: the kernel runner's
 * self-test (tests/test_gl_kernel.c, shaders/test_jacobi.comp) and the shape of the
 * propagation solvers to come (a 6-neighbour gather over ping-pong grids with a residual
 * after each step). Include after vs_common.h.
 *
 * vs_jacobi_item solves -Laplace(u) = f on an nx x ny x nz grid of unit spacing with u = 0 outside:
 * u'(c) = (sum of the 6 neighbours of c + f(c)) / 6. Item n is voxel
 * (n % nx, (n / nx) % ny, n / (nx ny)). */
#ifndef VS_STENCIL_H
#define VS_STENCIL_H

VS_FUNC float vs_jacobi_item(VS_DATA_PARAM(float, u_in) VS_DATA_PARAM(float, rhs) int n, int nx,
                             int ny, int nz)
{
    int i = n % nx;
    int j = (n / nx) % ny;
    int k = n / (nx * ny);
    float xm = i > 0 ? u_in[n - 1] : 0.0f;
    float xp = i + 1 < nx ? u_in[n + 1] : 0.0f;
    float ym = j > 0 ? u_in[n - nx] : 0.0f;
    float yp = j + 1 < ny ? u_in[n + nx] : 0.0f;
    float zm = k > 0 ? u_in[n - nx * ny] : 0.0f;
    float zp = k + 1 < nz ? u_in[n + nx * ny] : 0.0f;
    VS_PRECISE float s = ((xm + xp) + (ym + yp)) + ((zm + zp) + rhs[n]);
    VS_PRECISE float u = s * (1.0f / 6.0f);
    return u;
}

/* One step of a sweep in dependency order along the slowest axis: step k sets plane k,
 * u(k) = u(k-1) / 2 + f(k) (u(-1) = 0), reading plane k - 1 of the same state. Item n of
 * step k is element n + k * plane. */
VS_FUNC float vs_sweep_item(VS_DATA_PARAM(float, u_in) VS_DATA_PARAM(float, rhs) int n, int plane,
                            int k)
{
    int m = n + k * plane;
    float previous = k > 0 ? u_in[m - plane] : 0.0f;
    VS_PRECISE float u = 0.5f * previous + rhs[m];
    return u;
}

#endif
