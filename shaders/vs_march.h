/* Optical depth along a ray through a NanoVDB float density grid, shared by C and GLSL.
 *
 * The density is the trilinear interpolant of the voxel-centre values (voxel (i,j,k)
 * has its centre at index point (i,j,k); inactive voxels are 0). Rays are marched in
 * index space over the dual lattice whose cells have voxel centres as corners; along a
 * ray the interpolant inside one cell is a cubic in t, so Simpson's rule on each cell
 * segment integrates it exactly. Tiles of value 0 higher in the tree are skipped whole:
 * an empty node covering voxels [b, b+D) makes the interpolant vanish on the closed
 * box [b, b+D-1] in index space.
 *
 * The ray is x(t) = origin + t * dir in index space, where dir is the index-space image
 * of a unit world-space step, so t is measured in world units (non-uniform and
 * rotated voxels included).
 */
#ifndef VS_MARCH_H
#define VS_MARCH_H

/* Beyond this optical depth the transmittance is 0 in float: stop marching. */
#define VS_TAU_LIMIT 100.0f
/* Guard against a degenerate ray; far more cells than any real ray crosses. */
#define VS_MARCH_MAX_STEPS 4194304

VS_FUNC float vs_density_voxel(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                               pnanovdb_coord_t ijk)
{
    pnanovdb_address_t address = pnanovdb_readaccessor_get_value_address(
        PNANOVDB_GRID_TYPE_FLOAT, buf, acc, PNANOVDB_REF(ijk));
    return pnanovdb_read_float(buf, address);
}

VS_FUNC pnanovdb_readaccessor_t vs_density_accessor(pnanovdb_buf_t buf)
{
    pnanovdb_grid_handle_t grid;
    grid.address = pnanovdb_address_null();
    pnanovdb_root_handle_t root = pnanovdb_tree_get_root(buf, pnanovdb_grid_get_tree(buf, grid));
    pnanovdb_readaccessor_t acc;
    pnanovdb_readaccessor_init(PNANOVDB_REF(acc), root);
    return acc;
}

/* The eight corner values of the dual cell whose lowest corner is voxel c. */
struct vs_cell {
    float v000, v100, v010, v110, v001, v101, v011, v111;
};
PNANOVDB_STRUCT_TYPEDEF(vs_cell)

VS_FUNC vs_cell vs_cell_fetch(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                              pnanovdb_coord_t c)
{
    vs_cell cell;
    cell.v000 = vs_density_voxel(buf, acc, vs_coord(c.x, c.y, c.z));
    cell.v100 = vs_density_voxel(buf, acc, vs_coord(c.x + 1, c.y, c.z));
    cell.v010 = vs_density_voxel(buf, acc, vs_coord(c.x, c.y + 1, c.z));
    cell.v110 = vs_density_voxel(buf, acc, vs_coord(c.x + 1, c.y + 1, c.z));
    cell.v001 = vs_density_voxel(buf, acc, vs_coord(c.x, c.y, c.z + 1));
    cell.v101 = vs_density_voxel(buf, acc, vs_coord(c.x + 1, c.y, c.z + 1));
    cell.v011 = vs_density_voxel(buf, acc, vs_coord(c.x, c.y + 1, c.z + 1));
    cell.v111 = vs_density_voxel(buf, acc, vs_coord(c.x + 1, c.y + 1, c.z + 1));
    return cell;
}

/* The cell one step along an axis shares a face with this one: shifts the shared corners
 * into place and fetches only the four new ones (half the lookups of a fresh fetch).
 * axis 0 / 1 / 2 = x / y / z, sign the step; c is the new cell. Written out per axis: a
 * generic form (face getters and setters indexed by axis) made the C march 10% slower. */
VS_FUNC vs_cell vs_cell_step(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                             vs_cell old, pnanovdb_coord_t c, int axis, int sign)
{
    vs_cell cell = old;
    if (axis == 0) {
        int x = sign > 0 ? c.x + 1 : c.x;
        if (sign > 0) {
            cell.v000 = old.v100;
            cell.v010 = old.v110;
            cell.v001 = old.v101;
            cell.v011 = old.v111;
        } else {
            cell.v100 = old.v000;
            cell.v110 = old.v010;
            cell.v101 = old.v001;
            cell.v111 = old.v011;
        }
        float a = vs_density_voxel(buf, acc, vs_coord(x, c.y, c.z));
        float b = vs_density_voxel(buf, acc, vs_coord(x, c.y + 1, c.z));
        float d = vs_density_voxel(buf, acc, vs_coord(x, c.y, c.z + 1));
        float e = vs_density_voxel(buf, acc, vs_coord(x, c.y + 1, c.z + 1));
        if (sign > 0) {
            cell.v100 = a;
            cell.v110 = b;
            cell.v101 = d;
            cell.v111 = e;
        } else {
            cell.v000 = a;
            cell.v010 = b;
            cell.v001 = d;
            cell.v011 = e;
        }
    } else if (axis == 1) {
        int y = sign > 0 ? c.y + 1 : c.y;
        if (sign > 0) {
            cell.v000 = old.v010;
            cell.v100 = old.v110;
            cell.v001 = old.v011;
            cell.v101 = old.v111;
        } else {
            cell.v010 = old.v000;
            cell.v110 = old.v100;
            cell.v011 = old.v001;
            cell.v111 = old.v101;
        }
        float a = vs_density_voxel(buf, acc, vs_coord(c.x, y, c.z));
        float b = vs_density_voxel(buf, acc, vs_coord(c.x + 1, y, c.z));
        float d = vs_density_voxel(buf, acc, vs_coord(c.x, y, c.z + 1));
        float e = vs_density_voxel(buf, acc, vs_coord(c.x + 1, y, c.z + 1));
        if (sign > 0) {
            cell.v010 = a;
            cell.v110 = b;
            cell.v011 = d;
            cell.v111 = e;
        } else {
            cell.v000 = a;
            cell.v100 = b;
            cell.v001 = d;
            cell.v101 = e;
        }
    } else {
        int z = sign > 0 ? c.z + 1 : c.z;
        if (sign > 0) {
            cell.v000 = old.v001;
            cell.v100 = old.v101;
            cell.v010 = old.v011;
            cell.v110 = old.v111;
        } else {
            cell.v001 = old.v000;
            cell.v101 = old.v100;
            cell.v011 = old.v010;
            cell.v111 = old.v110;
        }
        float a = vs_density_voxel(buf, acc, vs_coord(c.x, c.y, z));
        float b = vs_density_voxel(buf, acc, vs_coord(c.x + 1, c.y, z));
        float d = vs_density_voxel(buf, acc, vs_coord(c.x, c.y + 1, z));
        float e = vs_density_voxel(buf, acc, vs_coord(c.x + 1, c.y + 1, z));
        if (sign > 0) {
            cell.v001 = a;
            cell.v101 = b;
            cell.v011 = d;
            cell.v111 = e;
        } else {
            cell.v000 = a;
            cell.v100 = b;
            cell.v010 = d;
            cell.v110 = e;
        }
    }
    return cell;
}

/* Trilinear interpolation inside a cell at local coordinates f in [0,1]^3. */
VS_FUNC float vs_cell_eval(vs_cell cell, pnanovdb_vec3_t f)
{
    VS_PRECISE float x00 = cell.v000 + (cell.v100 - cell.v000) * f.x;
    VS_PRECISE float x10 = cell.v010 + (cell.v110 - cell.v010) * f.x;
    VS_PRECISE float x01 = cell.v001 + (cell.v101 - cell.v001) * f.x;
    VS_PRECISE float x11 = cell.v011 + (cell.v111 - cell.v011) * f.x;
    VS_PRECISE float y0 = x00 + (x10 - x00) * f.y;
    VS_PRECISE float y1 = x01 + (x11 - x01) * f.y;
    VS_PRECISE float v = y0 + (y1 - y0) * f.z;
    return v;
}

/* Interpolated density at an index-space point (for samplers and tests). */
VS_FUNC float vs_density_at(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                            pnanovdb_vec3_t p)
{
    pnanovdb_coord_t c =
        vs_coord(VS_INT(vs_floor(p.x)), VS_INT(vs_floor(p.y)), VS_INT(vs_floor(p.z)));
    vs_cell cell = vs_cell_fetch(buf, acc, c);
    return vs_cell_eval(cell,
                        vs_vec3(p.x - VS_FLOAT(c.x), p.y - VS_FLOAT(c.y), p.z - VS_FLOAT(c.z)));
}

/* Parameter where the ray leaves the box [lo, hi] along axis component (o, d). */
VS_FUNC float vs_axis_exit(float o, float d, float lo, float hi)
{
    if (d > 0.0f)
        return (hi - o) / d;
    if (d < 0.0f)
        return (lo - o) / d;
    return VS_T_INFINITE;
}

VS_FUNC float vs_axis_enter(float o, float d, float lo, float hi)
{
    if (d > 0.0f)
        return (lo - o) / d;
    if (d < 0.0f)
        return (hi - o) / d;
    return (o >= lo && o <= hi) ? -VS_T_INFINITE : VS_T_INFINITE;
}

/* Where the ray o + t d (t >= 0) enters the box [lo, hi], and where it leaves it (an exit
 * before the entry: it misses). */
VS_FUNC float vs_box_enter(pnanovdb_vec3_t o, pnanovdb_vec3_t d, pnanovdb_vec3_t lo,
                           pnanovdb_vec3_t hi)
{
    return vs_max(0.0f, vs_max(vs_axis_enter(o.x, d.x, lo.x, hi.x),
                               vs_max(vs_axis_enter(o.y, d.y, lo.y, hi.y),
                                      vs_axis_enter(o.z, d.z, lo.z, hi.z))));
}

VS_FUNC float vs_box_exit(pnanovdb_vec3_t o, pnanovdb_vec3_t d, pnanovdb_vec3_t lo,
                          pnanovdb_vec3_t hi)
{
    return vs_min(vs_axis_exit(o.x, d.x, lo.x, hi.x),
                  vs_min(vs_axis_exit(o.y, d.y, lo.y, hi.y), vs_axis_exit(o.z, d.z, lo.z, hi.z)));
}

/* A march in progress along x(t) = origin + t dir, so that a caller can read the optical
 * depth at several t along one ray (a light grid's column) without marching again:
 * vs_march_begin, then vs_march_advance to increasing t, reading tau in between. */
struct vs_march_state {
    pnanovdb_vec3_t origin;
    pnanovdb_vec3_t dir;
    float t;  /* how far the march has integrated */
    float t1; /* end of the ray inside the box (and tmax) */
    float probe;
    pnanovdb_vec3_t delta; /* t per cell along each axis */
    pnanovdb_coord_t sign; /* step direction per axis */
    pnanovdb_coord_t c;    /* current cell */
    pnanovdb_vec3_t next;  /* t at the current cell's exit per axis */
    int locate;            /* 1: find the cell at t first */
    int fetched;           /* 1: `cell` holds the current cell's corners; 0: fetch them; 2 + axis:
                              `cell` holds the previous cell's, one step along axis away */
    vs_cell cell;
    int steps;
    int done; /* past VS_TAU_LIMIT, the end, or the step guard */
    float density_scale;
    vs_accum tau;
};
PNANOVDB_STRUCT_TYPEDEF(vs_march_state)

/* Starts a march over t in [0, tmax] from index-space point origin along dir, the
 * index-space image of a unit world step (t in world units); only the box [box_lo, box_hi]
 * (the support of the interpolant) is marched. */
VS_FUNC vs_march_state vs_march_begin(pnanovdb_vec3_t origin, pnanovdb_vec3_t dir, float tmax,
                                      pnanovdb_vec3_t box_lo, pnanovdb_vec3_t box_hi,
                                      float density_scale)
{
    vs_march_state m;
    m.origin = origin;
    m.dir = dir;
    m.t = vs_box_enter(origin, dir, box_lo, box_hi);
    m.t1 = vs_min(tmax, vs_box_exit(origin, dir, box_lo, box_hi));
    vs_accum_init(PNANOVDB_REF(m.tau));
    m.density_scale = density_scale;
    m.done = !(m.t < m.t1) || density_scale <= 0.0f ? 1 : 0;
    /* Cells are found by probing a thousandth of a voxel ahead, relative to the cell
     * size rather than to t, so that the probe never lands back in the previous cell. */
    float dmax = vs_max(vs_abs(dir.x), vs_max(vs_abs(dir.y), vs_abs(dir.z)));
    m.probe = 1.0e-3f / dmax;
    m.delta = vs_vec3(dir.x != 0.0f ? vs_abs(1.0f / dir.x) : VS_T_INFINITE,
                      dir.y != 0.0f ? vs_abs(1.0f / dir.y) : VS_T_INFINITE,
                      dir.z != 0.0f ? vs_abs(1.0f / dir.z) : VS_T_INFINITE);
    m.sign = vs_coord(dir.x > 0.0f ? 1 : (dir.x < 0.0f ? -1 : 0),
                      dir.y > 0.0f ? 1 : (dir.y < 0.0f ? -1 : 0),
                      dir.z > 0.0f ? 1 : (dir.z < 0.0f ? -1 : 0));
    m.c = vs_coord(0, 0, 0);
    m.next = vs_vec3(0.0f, 0.0f, 0.0f);
    m.locate = 1;
    m.fetched = 0;
    m.cell.v000 = m.cell.v100 = m.cell.v010 = m.cell.v110 = 0.0f;
    m.cell.v001 = m.cell.v101 = m.cell.v011 = m.cell.v111 = 0.0f;
    m.steps = 0;
    return m;
}

/* The steps of vs_march_advance, inlined into its loop like it (VS_FUNC_HOT). */

/* The cell at t, found by the probe a little ahead (vs_march_begin), and the t at which the
 * ray leaves it along each axis. */
VS_FUNC_HOT void vs_march_locate(pnanovdb_vec3_t origin, pnanovdb_vec3_t dir, float t, float probe,
                                 PNANOVDB_INOUT(pnanovdb_coord_t) cell_at,
                                 PNANOVDB_INOUT(pnanovdb_vec3_t) next)
{
    pnanovdb_vec3_t q = vs_vec3_madd(origin, dir, t + probe);
    pnanovdb_coord_t c =
        vs_coord(VS_INT(vs_floor(q.x)), VS_INT(vs_floor(q.y)), VS_INT(vs_floor(q.z)));
    PNANOVDB_DEREF(next).x =
        vs_max(t, vs_axis_exit(origin.x, dir.x, VS_FLOAT(c.x), VS_FLOAT(c.x + 1)));
    PNANOVDB_DEREF(next).y =
        vs_max(t, vs_axis_exit(origin.y, dir.y, VS_FLOAT(c.y), VS_FLOAT(c.y + 1)));
    PNANOVDB_DEREF(next).z =
        vs_max(t, vs_axis_exit(origin.z, dir.z, VS_FLOAT(c.z), VS_FLOAT(c.z + 1)));
    PNANOVDB_DEREF(cell_at) = c;
}

/* Where the ray leaves the empty tile that holds the whole cell c (corners c and c + 1), or
 * -VS_T_INFINITE when the cell is not known to be empty. */
VS_FUNC_HOT float vs_march_empty_exit(pnanovdb_buf_t buf,
                                      PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                      pnanovdb_vec3_t origin, pnanovdb_vec3_t dir,
                                      pnanovdb_coord_t c)
{
    int dim =
        VS_INT(pnanovdb_readaccessor_get_dim(PNANOVDB_GRID_TYPE_FLOAT, buf, acc, PNANOVDB_REF(c)));
    int last = dim - 1;
    if (dim > 1 && (c.x & last) != last && (c.y & last) != last && (c.z & last) != last &&
        vs_density_voxel(buf, acc, c) == 0.0f) {
        int mask = ~last;
        float hi = VS_FLOAT(last);
        float bx = VS_FLOAT(c.x & mask), by = VS_FLOAT(c.y & mask), bz = VS_FLOAT(c.z & mask);
        return vs_min(vs_axis_exit(origin.x, dir.x, bx, bx + hi),
                      vs_min(vs_axis_exit(origin.y, dir.y, by, by + hi),
                             vs_axis_exit(origin.z, dir.z, bz, bz + hi)));
    }
    return -VS_T_INFINITE;
}

/* The corners of cell c: fetched whole (fetched 0), or stepped from the previous cell's
 * `cell` one step along axis fetched - 2. */
VS_FUNC_HOT vs_cell vs_march_fetch(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                   vs_cell cell, pnanovdb_coord_t c, int fetched,
                                   pnanovdb_coord_t sign)
{
    if (fetched == 0)
        return vs_cell_fetch(buf, acc, c);
    int axis = fetched - 2;
    return vs_cell_step(buf, acc, cell, c, axis,
                        axis == 0 ? sign.x : (axis == 1 ? sign.y : sign.z));
}

/* Simpson's rule for the optical depth over [t, t_exit] inside cell c. */
VS_FUNC_HOT float vs_march_simpson(vs_cell cell, pnanovdb_coord_t c, pnanovdb_vec3_t origin,
                                   pnanovdb_vec3_t dir, float t, float t_exit, float density_scale)
{
    pnanovdb_vec3_t local =
        vs_vec3(origin.x - VS_FLOAT(c.x), origin.y - VS_FLOAT(c.y), origin.z - VS_FLOAT(c.z));
    float fa = vs_cell_eval(cell, vs_vec3_madd(local, dir, t));
    float fm = vs_cell_eval(cell, vs_vec3_madd(local, dir, 0.5f * (t + t_exit)));
    float fb = vs_cell_eval(cell, vs_vec3_madd(local, dir, t_exit));
    VS_PRECISE float segment = (t_exit - t) * (fa + 4.0f * fm + fb) * (1.0f / 6.0f) * density_scale;
    return segment;
}

/* Steps c into the next cell, which shares a face with it; returns the `fetched` code of
 * that step (2 + axis). */
VS_FUNC_HOT int vs_march_next_cell(PNANOVDB_INOUT(pnanovdb_coord_t) c,
                                   PNANOVDB_INOUT(pnanovdb_vec3_t) next, pnanovdb_coord_t sign,
                                   pnanovdb_vec3_t delta)
{
    if (PNANOVDB_DEREF(next).x <= PNANOVDB_DEREF(next).y &&
        PNANOVDB_DEREF(next).x <= PNANOVDB_DEREF(next).z) {
        PNANOVDB_DEREF(c).x += sign.x;
        PNANOVDB_DEREF(next).x += delta.x;
        return 2;
    }
    if (PNANOVDB_DEREF(next).y <= PNANOVDB_DEREF(next).z) {
        PNANOVDB_DEREF(c).y += sign.y;
        PNANOVDB_DEREF(next).y += delta.y;
        return 3;
    }
    PNANOVDB_DEREF(c).z += sign.z;
    PNANOVDB_DEREF(next).z += delta.z;
    return 4;
}

/* Integrates on to t_target (or the ray's end), cell by cell with Simpson's rule, which is
 * exact for the trilinear interpolant's cubic on any part of a cell. Stops for good once the
 * depth passes VS_TAU_LIMIT (transmittance 0 in float). */
VS_FUNC_HOT void vs_march_advance(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                  PNANOVDB_INOUT(vs_march_state) m, float t_target)
{
    if (PNANOVDB_DEREF(m).done != 0)
        return;
    pnanovdb_vec3_t origin = PNANOVDB_DEREF(m).origin;
    pnanovdb_vec3_t dir = PNANOVDB_DEREF(m).dir;
    float probe = PNANOVDB_DEREF(m).probe;
    float t_stop = vs_min(PNANOVDB_DEREF(m).t1, t_target);
    float t = PNANOVDB_DEREF(m).t;
    pnanovdb_coord_t c = PNANOVDB_DEREF(m).c;
    pnanovdb_vec3_t next = PNANOVDB_DEREF(m).next;
    int locate = PNANOVDB_DEREF(m).locate;
    int fetched = PNANOVDB_DEREF(m).fetched;
    vs_cell cell = PNANOVDB_DEREF(m).cell;
    int step = PNANOVDB_DEREF(m).steps;
    for (; step < VS_MARCH_MAX_STEPS && t < t_stop; ++step) {
        if (locate != 0) {
            vs_march_locate(origin, dir, t, probe, PNANOVDB_REF(c), PNANOVDB_REF(next));
            locate = 0;
            fetched = 0;
        }
        /* A cell is checked and fetched once, however many stops a caller makes in it. */
        if (fetched != 1) {
            float t_empty = vs_march_empty_exit(buf, acc, origin, dir, c);
            if (t_empty > t + probe) {
                t = t_empty;
                locate = 1;
                continue;
            }
            cell = vs_march_fetch(buf, acc, cell, c, fetched, PNANOVDB_DEREF(m).sign);
            fetched = 1;
        }
        float t_cell = vs_min(next.x, vs_min(next.y, next.z));
        float t_exit = vs_min(t_stop, t_cell);
        if (t_exit > t) {
            vs_accum_add(
                PNANOVDB_REF(PNANOVDB_DEREF(m).tau),
                vs_march_simpson(cell, c, origin, dir, t, t_exit, PNANOVDB_DEREF(m).density_scale));
            if (vs_accum_value(PNANOVDB_DEREF(m).tau) > VS_TAU_LIMIT) {
                PNANOVDB_DEREF(m).done = 1;
                break;
            }
            t = t_exit;
        }
        /* Stopped inside the cell at t_target: resume there later. */
        if (t_exit < t_cell && t_exit >= t_stop)
            break;
        /* The next cell shares a face with this one (fetched == 1 here). */
        fetched = vs_march_next_cell(PNANOVDB_REF(c), PNANOVDB_REF(next), PNANOVDB_DEREF(m).sign,
                                     PNANOVDB_DEREF(m).delta);
    }
    PNANOVDB_DEREF(m).t = t;
    PNANOVDB_DEREF(m).c = c;
    PNANOVDB_DEREF(m).next = next;
    PNANOVDB_DEREF(m).locate = locate;
    PNANOVDB_DEREF(m).fetched = fetched;
    PNANOVDB_DEREF(m).cell = cell;
    PNANOVDB_DEREF(m).steps = step;
    if (step >= VS_MARCH_MAX_STEPS || !(t < PNANOVDB_DEREF(m).t1))
        PNANOVDB_DEREF(m).done = 1;
}

/* Optical depth sigma_t integrated over t in [0, tmax] from index-space point origin
 * along dir, sigma_t = density * density_scale, as an accumulator (see vs_accum_exp_neg).
 * Only the box [box_lo, box_hi] (index space, the support of the interpolant) is
 * marched. Stops early once the depth passes VS_TAU_LIMIT (transmittance 0 in float). */
VS_FUNC vs_accum vs_march(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                          pnanovdb_vec3_t origin, pnanovdb_vec3_t dir, float tmax,
                          pnanovdb_vec3_t box_lo, pnanovdb_vec3_t box_hi, float density_scale)
{
    vs_march_state m = vs_march_begin(origin, dir, tmax, box_lo, box_hi, density_scale);
    vs_march_advance(buf, acc, PNANOVDB_REF(m), VS_T_INFINITE);
    return m.tau;
}

VS_FUNC float vs_optical_depth(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                               pnanovdb_vec3_t origin, pnanovdb_vec3_t dir, float tmax,
                               pnanovdb_vec3_t box_lo, pnanovdb_vec3_t box_hi, float density_scale)
{
    return vs_accum_value(vs_march(buf, acc, origin, dir, tmax, box_lo, box_hi, density_scale));
}

/* exp(-optical depth) along the same ray. */
VS_FUNC float vs_transmittance(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                               pnanovdb_vec3_t origin, pnanovdb_vec3_t dir, float tmax,
                               pnanovdb_vec3_t box_lo, pnanovdb_vec3_t box_hi, float density_scale)
{
    return vs_accum_exp_neg(vs_march(buf, acc, origin, dir, tmax, box_lo, box_hi, density_scale));
}

#endif
