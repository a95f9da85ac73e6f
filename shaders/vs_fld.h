/* Flux-limited diffusion (Koerner et al. 2014), shared by C and GLSL: the parameter and
 * coefficient layouts of the discrete steady equation -div(D grad phi) + sigma_a phi = Q on a
 * grid of cubic cells, and its operator y = A x for one colour channel. Include after
 * vs_common.h. Host side: vdbscatter/solvers/fld.c.
 *
 * Cell-centred finite volumes: per cell and channel sigma_a, the Marshak leak of its boundary
 * faces (per volume) and the couplings D_face / h^2 to the +x, +y and +z neighbours (0 at the
 * grid's far faces); the -x coupling of a cell is its -x
 * neighbour's +x one, so A is symmetric. The operator is applied as (sigma_a + leak) x_i +
 * sum of couplings (x_i - x_neighbour): absorption is never folded into a float diagonal whose
 * couplings dwarf it, and the power balance of the float operator is exactly absorbed + leaked.
 * Cell (i, j, k) is item (k n1 + j) n0 + i. */
#ifndef VS_FLD_H
#define VS_FLD_H

/* Parameter words (uints). */
#define VS_FLD_OFF_N 0       /* 3: cells along x, y, z */
#define VS_FLD_OFF_CHANNEL 3 /* the colour channel this operator applies */
#define VS_FLD_PARAM_WORDS 4

/* Coefficients: VS_FLD_COEF_WORDS floats per cell and channel, at (cell 3 + channel) words. */
#define VS_FLD_COEF_ABSORB 0 /* sigma_a */
#define VS_FLD_COEF_LEAK 1   /* the boundary faces' Marshak leak per volume */
#define VS_FLD_COEF_X 2      /* coupling to the +x neighbour */
#define VS_FLD_COEF_Y 3
#define VS_FLD_COEF_Z 4
#define VS_FLD_COEF_WORDS 5

VS_FUNC int vs_fld_coef_at(int cell, int channel, int k)
{
    return (cell * 3 + channel) * VS_FLD_COEF_WORDS + k;
}

/* (A x) at `cell` for the parameters' channel; x holds one value per cell. */
VS_FUNC float vs_fld_apply(VS_DATA_PARAM(vs_uint, fld_params) VS_DATA_PARAM(float, fld_coef)
                               VS_DATA_PARAM(float, fld_x) int cell)
{
    int n0 = VS_INT(fld_params[VS_FLD_OFF_N]);
    int n1 = VS_INT(fld_params[VS_FLD_OFF_N + 1]);
    int n2 = VS_INT(fld_params[VS_FLD_OFF_N + 2]);
    int ch = VS_INT(fld_params[VS_FLD_OFF_CHANNEL]);
    int i = cell % n0;
    int j = (cell / n0) % n1;
    int k = cell / (n0 * n1);
    float xi = fld_x[cell];
    VS_PRECISE float y = (fld_coef[vs_fld_coef_at(cell, ch, VS_FLD_COEF_ABSORB)] +
                          fld_coef[vs_fld_coef_at(cell, ch, VS_FLD_COEF_LEAK)]) *
                         xi;
    if (i + 1 < n0)
        y += fld_coef[vs_fld_coef_at(cell, ch, VS_FLD_COEF_X)] * (xi - fld_x[cell + 1]);
    if (i > 0)
        y += fld_coef[vs_fld_coef_at(cell - 1, ch, VS_FLD_COEF_X)] * (xi - fld_x[cell - 1]);
    if (j + 1 < n1)
        y += fld_coef[vs_fld_coef_at(cell, ch, VS_FLD_COEF_Y)] * (xi - fld_x[cell + n0]);
    if (j > 0)
        y += fld_coef[vs_fld_coef_at(cell - n0, ch, VS_FLD_COEF_Y)] * (xi - fld_x[cell - n0]);
    if (k + 1 < n2)
        y += fld_coef[vs_fld_coef_at(cell, ch, VS_FLD_COEF_Z)] * (xi - fld_x[cell + n0 * n1]);
    if (k > 0)
        y += fld_coef[vs_fld_coef_at(cell - n0 * n1, ch, VS_FLD_COEF_Z)] *
             (xi - fld_x[cell - n0 * n1]);
    return y;
}

#endif
