/* Deterministic ray-marched rendering (`render --mode single|baked`, later the viewer),
 * shared by C and GLSL. Include after vs_common.h, vs_march.h, vs_phase.h, vs_medium.h,
 * vs_shadow.h, vs_lights.h, vs_lightgrid.h and vs_envmap.h.
 *
 * Along a camera ray, L = integral T(0,t) sigma_s(x) S(x, wo) dt + T_total L_background,
 * with S = S1 (+ Sms in baked mode). The ray is cut into segments of step_voxels voxels
 * inside the support box; each segment [a,b] adds (T_a - T_b) * albedo * S(mid), the exact
 * integral when S is constant on the segment (sigma_s = albedo sigma_t and
 * integral T sigma_t dt = T_a - T_b), so thick media never overshoot. T comes from the
 * exact march of the trilinear density (vs_march.h). S1 is exact for suns and point
 * lights (marched transmittance times HG) and a fixed K-direction quadrature for the
 * constant sky; Sms is reconstructed from trilinear samples of the lit VDB's ms and
 * ms_l1x/y/z grids (docs/lit-vdb.md).
 *
 * The work of a ray is a sequence of units, each exactly one march (the camera segment, or
 * the transmittance toward one light or sky direction from the segment's midpoint), kept
 * in a vs_render_state so that it can stop after any unit and resume in a later dispatch
 * (the runner's passes, vs_pass.h: a whole ray at quality medium does not fit in one
 * invocation under llvmpipe). One march per unit through a single call site bounds the
 * iterations of a unit by the march's cell count, whatever the SIMD lanes do.
 *
 * All grids live in one buffer (GLSL has a single pnanovdb_buf_data): the density grid at
 * byte 0, the four vec3 grids at the byte offsets stored in the render table. PNanoVDB
 * handles are addresses, so a grid at a non-zero offset reads like one at 0.
 *
 * Three tables: the medium (vs_medium.h), the lights (vs_lights.h) and this render table
 * (camera, step, grid offsets; written by vdbscatter/render/march_session.c). The sky's S1
 * sums the light table's ordinates, each with its own radiance, so that non-uniform skies
 * need no change.
 *
 * With light grids (vs_lightgrid.h; the render table says so), the transmittance toward a
 * light or sky ordinate is a lookup in its grid, one grid per light in the light table's
 * order, instead of a march: the units stay the same, only the camera segment marches. A
 * lit VDB's stored depths (VS_LGRID_VOXEL) are such grids too, float grids in this buffer
 * sampled trilinearly at the segment's midpoint.
 */
#ifndef VS_RENDER_H
#define VS_RENDER_H

/* (step in voxels, 1 when the ms grids are present, 1 when light grids are, 0) */
#define VS_RENDER_OFF_MARCH 0
/* Grid offsets in units of 32 bytes, split as (hi, lo) = (offset >> 16, offset & 0xffff) so
 * that floats hold them exactly: (ms hi, ms lo, l1x hi, l1x lo), (l1y hi, lo, l1z hi, lo). */
#define VS_RENDER_OFF_GRIDS 1
#define VS_RENDER_OFF_GRIDS_L1YZ 2
/* Camera origin in index space (xyz), image width (w). */
#define VS_RENDER_OFF_ORIGIN 3
/* Camera forward, world (xyz), image height (w). */
#define VS_RENDER_OFF_FORWARD 4
/* Camera right * tan(half horizontal fov), up * tan(half vertical fov), world (xyz). */
#define VS_RENDER_OFF_RIGHT 5
#define VS_RENDER_OFF_UP 6
/* The viewer's knobs, neutral for `render`: (interleave block M, 1 to include S1, 0, 0).
 * With M > 1 the segments are dealt out over M x M pixel blocks (interleaved sampling,
 * Keller and Heidrich 2001; Toth and Umenhoffer 2009 4.1): pixel (px, py) has phase
 * k = px mod M + M (py mod M) and evaluates S (the units toward the lights and the Sms
 * sample) only on segments j = k mod M^2, weighted M^2; every segment still marches its
 * own transmittance, so the weights stay exact in heterogeneous media. A box filter of
 * M x M (vs_gather.h) then sums the block's phases back into every segment. */
#define VS_RENDER_OFF_VIEW 7
/* The camera's world position (xyz; the occluders' shadow maps are looked up in world
 * space, vs_shadow.h) and 1 when a backdrop is given (w): per pixel a vec4 (distance along
 * the ray to the first solid surface, its radiance rgb), the viewer's rasterised
 * occluders; the ray stops there and sees the surface instead of the background. */
#define VS_RENDER_OFF_WORLD_ORIGIN 8
#define VS_RENDER_SIZE 9

/* The three tables every render function reads: parameters in C, SSBOs in GLSL. */
#define VS_RENDER_TABLES                                                                           \
    VS_DATA_PARAM(vs_vec4, medium_data)                                                            \
    VS_DATA_PARAM(vs_vec4, light_data)                                                             \
    VS_DATA_PARAM(vs_vec4, render_data)                                                            \
    VS_DATA_PARAM(vs_uint, lgrid_data)                                                             \
    VS_DATA_PARAM(float, env_data)                                                                 \
    VS_DATA_PARAM(float, shadow_data) VS_DATA_PARAM(vs_vec4, backdrop_data)
#define VS_RENDER_TABLES_ARG                                                                       \
    VS_DATA_ARG(medium_data)                                                                       \
    VS_DATA_ARG(light_data)                                                                        \
    VS_DATA_ARG(render_data)                                                                       \
    VS_DATA_ARG(lgrid_data)                                                                        \
    VS_DATA_ARG(env_data) VS_DATA_ARG(shadow_data) VS_DATA_ARG(backdrop_data)

/* Guard on segments per camera ray (a step of 1/8 voxel across a 2^17-voxel grid). */
#define VS_RENDER_MAX_SEGMENTS 1048576

#if defined(PNANOVDB_GLSL)
VS_FUNC pnanovdb_address_t vs_render_grid_address(float hi, float lo)
{
    return pnanovdb_address_offset(pnanovdb_address_null(), (uint(hi) * 65536u + uint(lo)) * 32u);
}
#else
VS_FUNC pnanovdb_address_t vs_render_grid_address(float hi, float lo)
{
    return pnanovdb_address_offset64(pnanovdb_address_null(),
                                     ((uint64_t)hi * 65536u + (uint64_t)lo) * 32u);
}
#endif

VS_FUNC pnanovdb_readaccessor_t vs_grid_accessor(pnanovdb_buf_t buf, pnanovdb_address_t address)
{
    pnanovdb_grid_handle_t grid;
    grid.address = address;
    pnanovdb_root_handle_t root = pnanovdb_tree_get_root(buf, pnanovdb_grid_get_tree(buf, grid));
    pnanovdb_readaccessor_t acc;
    pnanovdb_readaccessor_init(PNANOVDB_REF(acc), root);
    return acc;
}

/* One read accessor per grid of the buffer (per thread / invocation). */
struct vs_render_accessors {
    pnanovdb_readaccessor_t density;
    pnanovdb_readaccessor_t ms;
    pnanovdb_readaccessor_t l1x;
    pnanovdb_readaccessor_t l1y;
    pnanovdb_readaccessor_t l1z;
};
PNANOVDB_STRUCT_TYPEDEF(vs_render_accessors)

VS_FUNC vs_render_accessors vs_render_accessors_init(VS_DATA_PARAM(vs_vec4, render_data)
                                                         pnanovdb_buf_t buf)
{
    vs_render_accessors a;
    a.density = vs_density_accessor(buf);
    if (render_data[VS_RENDER_OFF_MARCH].y != 0.0f) {
        vs_vec4 g = render_data[VS_RENDER_OFF_GRIDS];
        vs_vec4 h = render_data[VS_RENDER_OFF_GRIDS_L1YZ];
        a.ms = vs_grid_accessor(buf, vs_render_grid_address(g.x, g.y));
        a.l1x = vs_grid_accessor(buf, vs_render_grid_address(g.z, g.w));
        a.l1y = vs_grid_accessor(buf, vs_render_grid_address(h.x, h.y));
        a.l1z = vs_grid_accessor(buf, vs_render_grid_address(h.z, h.w));
    } else {
        a.ms = a.density;
        a.l1x = a.density;
        a.l1y = a.density;
        a.l1z = a.density;
    }
    return a;
}

/* Value of a NanoVDB Vec3f grid at a voxel (the background where inactive). */
VS_FUNC pnanovdb_vec3_t vs_vec3_voxel(pnanovdb_buf_t buf,
                                      PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                      pnanovdb_coord_t ijk)
{
    pnanovdb_address_t address = pnanovdb_readaccessor_get_value_address(
        PNANOVDB_GRID_TYPE_VEC3F, buf, acc, PNANOVDB_REF(ijk));
    return vs_vec3(pnanovdb_read_float(buf, address),
                   pnanovdb_read_float(buf, pnanovdb_address_offset(address, 4u)),
                   pnanovdb_read_float(buf, pnanovdb_address_offset(address, 8u)));
}

VS_FUNC pnanovdb_vec3_t vs_vec3_lerp(pnanovdb_vec3_t a, pnanovdb_vec3_t b, float t)
{
    VS_PRECISE float x = a.x + (b.x - a.x) * t;
    VS_PRECISE float y = a.y + (b.y - a.y) * t;
    VS_PRECISE float z = a.z + (b.z - a.z) * t;
    return vs_vec3(x, y, z);
}

/* Trilinear interpolant of a Vec3f grid over voxel centres (as vs_density_at). */
VS_FUNC pnanovdb_vec3_t vs_vec3_at(pnanovdb_buf_t buf, PNANOVDB_INOUT(pnanovdb_readaccessor_t) acc,
                                   pnanovdb_vec3_t p)
{
    pnanovdb_coord_t c =
        vs_coord(VS_INT(vs_floor(p.x)), VS_INT(vs_floor(p.y)), VS_INT(vs_floor(p.z)));
    float fx = p.x - VS_FLOAT(c.x);
    float fy = p.y - VS_FLOAT(c.y);
    float fz = p.z - VS_FLOAT(c.z);
    pnanovdb_vec3_t x00 = vs_vec3_lerp(vs_vec3_voxel(buf, acc, vs_coord(c.x, c.y, c.z)),
                                       vs_vec3_voxel(buf, acc, vs_coord(c.x + 1, c.y, c.z)), fx);
    pnanovdb_vec3_t x10 =
        vs_vec3_lerp(vs_vec3_voxel(buf, acc, vs_coord(c.x, c.y + 1, c.z)),
                     vs_vec3_voxel(buf, acc, vs_coord(c.x + 1, c.y + 1, c.z)), fx);
    pnanovdb_vec3_t x01 =
        vs_vec3_lerp(vs_vec3_voxel(buf, acc, vs_coord(c.x, c.y, c.z + 1)),
                     vs_vec3_voxel(buf, acc, vs_coord(c.x + 1, c.y, c.z + 1)), fx);
    pnanovdb_vec3_t x11 =
        vs_vec3_lerp(vs_vec3_voxel(buf, acc, vs_coord(c.x, c.y + 1, c.z + 1)),
                     vs_vec3_voxel(buf, acc, vs_coord(c.x + 1, c.y + 1, c.z + 1)), fx);
    return vs_vec3_lerp(vs_vec3_lerp(x00, x10, fy), vs_vec3_lerp(x01, x11, fy), fz);
}

/* 1 - exp(-x) for x >= 0 without the cancellation of the float subtraction for small x
 * (a segment of optical depth 1e-6 would be 6% off): Taylor series below 1/4, where its
 * first omitted term is below 1e-10 relative. */
VS_FUNC float vs_one_minus_exp_neg(float x)
{
    if (x < 0.25f) {
        VS_PRECISE float s = 1.0f - x * (1.0f / 8.0f);
        s = 1.0f - x * (1.0f / 7.0f) * s;
        s = 1.0f - x * (1.0f / 6.0f) * s;
        s = 1.0f - x * (1.0f / 5.0f) * s;
        s = 1.0f - x * (1.0f / 4.0f) * s;
        s = 1.0f - x * (1.0f / 3.0f) * s;
        s = 1.0f - x * 0.5f * s;
        VS_PRECISE float r = x * s;
        return r;
    }
    return 1.0f - vs_exp(-x);
}

/* Sms at index-space point p toward the world direction wo, from the baked grids. */
VS_FUNC pnanovdb_vec3_t vs_render_ms(pnanovdb_buf_t buf, PNANOVDB_INOUT(vs_render_accessors) accs,
                                     pnanovdb_vec3_t p, pnanovdb_vec3_t wo)
{
    pnanovdb_vec3_t ms = vs_vec3_at(buf, PNANOVDB_REF(PNANOVDB_DEREF(accs).ms), p);
    pnanovdb_vec3_t lx = vs_vec3_at(buf, PNANOVDB_REF(PNANOVDB_DEREF(accs).l1x), p);
    pnanovdb_vec3_t ly = vs_vec3_at(buf, PNANOVDB_REF(PNANOVDB_DEREF(accs).l1y), p);
    pnanovdb_vec3_t lz = vs_vec3_at(buf, PNANOVDB_REF(PNANOVDB_DEREF(accs).l1z), p);
    return vs_vec3(vs_ms_channel(ms.x, lx.x, ly.x, lz.x, wo),
                   vs_ms_channel(ms.y, lx.y, ly.y, lz.y, wo),
                   vs_ms_channel(ms.z, lx.z, ly.z, lz.z, wo));
}

/* One camera ray, set up once per pixel (and again on every resumed dispatch). */
struct vs_render_ray_info {
    pnanovdb_vec3_t origin; /* index space */
    pnanovdb_vec3_t dir;    /* index-space image of a unit world step */
    pnanovdb_vec3_t wo;     /* world, unit: -(ray direction) */
    float t0;               /* segments cover [t0, t0 + span] in n equal parts */
    int phase;              /* interleaved sampling: this pixel's segments are phase mod phases */
    int phases;             /* M^2, 1 without interleaving */
    pnanovdb_vec3_t world_origin; /* the camera, world */
    int backdrop;                 /* a solid surface ends the ray: backdrop_colour behind it */
    pnanovdb_vec3_t backdrop_colour;
    float span;
    float inv_n;
    int n; /* 0 when the ray misses the support box or the medium is empty */
};
PNANOVDB_STRUCT_TYPEDEF(vs_render_ray_info)

/* Progress of one ray, so that the work can stop after any unit and resume later. */
struct vs_render_state {
    int seg;      /* current segment */
    int unit;     /* 0: march the segment; then 1 + light index; then 1 + lights + ordinate */
    int stop;     /* 0 running; 1 last segment (the optical depth limit was passed); 2 done */
    vs_accum tau; /* optical depth from the camera to the end of the current segment */
    float transmittance;      /* exp(-tau) */
    float weight;             /* T_a - T_b of the current segment */
    pnanovdb_vec3_t source;   /* S so far at the current segment's midpoint */
    pnanovdb_vec3_t radiance; /* integral so far, background not included */
};
PNANOVDB_STRUCT_TYPEDEF(vs_render_state)

/* A ray's state between dispatches: 32-bit words at these offsets (floats as bits). */
#define VS_RENDER_STATE_SEG 0
#define VS_RENDER_STATE_UNIT 1
#define VS_RENDER_STATE_STOP 2
#define VS_RENDER_STATE_TAU_SUM 3
#define VS_RENDER_STATE_TAU_CARRY 4
#define VS_RENDER_STATE_TRANSMITTANCE 5
#define VS_RENDER_STATE_WEIGHT 6
#define VS_RENDER_STATE_SOURCE 7    /* 3 words */
#define VS_RENDER_STATE_RADIANCE 10 /* 3 words */
#define VS_RENDER_STATE_WORDS 13

VS_FUNC vs_render_ray_info vs_render_ray_begin(VS_DATA_PARAM(vs_vec4, medium_data)
                                                   VS_DATA_PARAM(vs_vec4, render_data)
                                                       pnanovdb_vec3_t origin,
                                               pnanovdb_vec3_t dir, pnanovdb_vec3_t wo,
                                               float t_surface)
{
    pnanovdb_vec3_t box_lo = vs_medium_box_lo(VS_DATA_ONLY_ARG(medium_data));
    pnanovdb_vec3_t box_hi = vs_medium_box_hi(VS_DATA_ONLY_ARG(medium_data));
    vs_render_ray_info ray;
    ray.origin = origin;
    ray.dir = dir;
    ray.wo = wo;
    ray.t0 = vs_box_enter(origin, dir, box_lo, box_hi);
    float t1 = vs_min(t_surface, vs_box_exit(origin, dir, box_lo, box_hi));
    ray.span = t1 - ray.t0;
    ray.n = 0;
    ray.inv_n = 1.0f;
    ray.phase = 0;
    ray.phases = 1;
    ray.world_origin = vs_vec3_from_vec4(render_data[VS_RENDER_OFF_WORLD_ORIGIN]);
    ray.backdrop = 0;
    ray.backdrop_colour = vs_vec3(0.0f, 0.0f, 0.0f);
    if (ray.t0 < t1 && vs_medium_density_scale(VS_DATA_ONLY_ARG(medium_data)) > 0.0f) {
        /* World length of step_voxels voxels along this ray. */
        float h = render_data[VS_RENDER_OFF_MARCH].x / vs_sqrt(vs_vec3_dot(dir, dir));
        float steps = ray.span / h;
        ray.n = steps < VS_FLOAT(VS_RENDER_MAX_SEGMENTS) ? VS_INT(vs_floor(steps)) + 1
                                                         : VS_RENDER_MAX_SEGMENTS;
        ray.inv_n = 1.0f / VS_FLOAT(ray.n);
    }
    return ray;
}

VS_FUNC int vs_render_width(VS_DATA_ONLY(vs_vec4, render_data))
{
    return VS_INT(render_data[VS_RENDER_OFF_ORIGIN].w);
}

/* The camera ray through the centre of pixel (px, py), row 0 on top. */
VS_FUNC vs_render_ray_info vs_render_camera_ray(VS_DATA_PARAM(vs_vec4, medium_data)
                                                    VS_DATA_PARAM(vs_vec4, render_data)
                                                        VS_DATA_PARAM(vs_vec4,
                                                                      backdrop_data) int px,
                                                int py)
{
    float width = render_data[VS_RENDER_OFF_ORIGIN].w;
    pnanovdb_vec3_t world =
        vs_pinhole_direction(render_data[VS_RENDER_OFF_FORWARD], render_data[VS_RENDER_OFF_RIGHT],
                             render_data[VS_RENDER_OFF_UP], width, px, py);
    pnanovdb_vec3_t dir = vs_medium_to_index(VS_DATA_ARG(medium_data) world);
    float t_surface = VS_T_INFINITE;
    pnanovdb_vec3_t surface_colour = vs_vec3(0.0f, 0.0f, 0.0f);
    if (render_data[VS_RENDER_OFF_WORLD_ORIGIN].w != 0.0f) {
        t_surface = backdrop_data[py * VS_INT(width) + px].x;
        surface_colour = vs_vec3(backdrop_data[py * VS_INT(width) + px].y,
                                 backdrop_data[py * VS_INT(width) + px].z,
                                 backdrop_data[py * VS_INT(width) + px].w);
    }
    vs_render_ray_info ray =
        vs_render_ray_begin(VS_DATA_ARG(medium_data) VS_DATA_ARG(render_data)
                                vs_vec3_from_vec4(render_data[VS_RENDER_OFF_ORIGIN]),
                            dir, vs_vec3_scale(world, -1.0f), t_surface);
    if (t_surface < VS_T_INFINITE) {
        ray.backdrop = 1;
        ray.backdrop_colour = surface_colour;
    }
    int m = VS_INT(render_data[VS_RENDER_OFF_VIEW].x);
    if (m > 1) {
        ray.phase = px % m + m * (py % m);
        ray.phases = m * m;
    }
    return ray;
}

VS_FUNC vs_render_state vs_render_state_init(vs_render_ray_info ray)
{
    vs_render_state st;
    st.seg = 0;
    st.unit = 0;
    st.stop = ray.n > 0 ? 0 : 2;
    vs_accum_init(PNANOVDB_REF(st.tau));
    st.transmittance = 1.0f;
    st.weight = 0.0f;
    st.source = vs_vec3(0.0f, 0.0f, 0.0f);
    st.radiance = vs_vec3(0.0f, 0.0f, 0.0f);
    return st;
}

VS_FUNC void vs_render_next_segment(vs_render_ray_info ray, PNANOVDB_INOUT(vs_render_state) st)
{
    PNANOVDB_DEREF(st).unit = 0;
    PNANOVDB_DEREF(st).seg += 1;
    if (PNANOVDB_DEREF(st).stop == 1 || PNANOVDB_DEREF(st).seg >= ray.n)
        PNANOVDB_DEREF(st).stop = 2;
}

/* Where segment k of the ray begins (k = ray.n: where the last one ends). */
VS_FUNC float vs_render_segment_at(vs_render_ray_info ray, int k)
{
    VS_PRECISE float t =
        k == ray.n ? ray.t0 + ray.span : ray.t0 + ray.span * (VS_FLOAT(k) * ray.inv_n);
    return t;
}

/* What a unit marches (from origin along dir over [0, tmax]) and how the transmittance it
 * finds adds to S: color * T * phase * falloff. */
struct vs_render_target {
    pnanovdb_vec3_t origin;
    pnanovdb_vec3_t dir;
    float tmax;
    float phase;
    float falloff;
    pnanovdb_vec3_t color;
};
PNANOVDB_STRUCT_TYPEDEF(vs_render_target)

/* Toward direct light `light` (a sun or a point light) from the segment's midpoint. */
VS_FUNC vs_render_target vs_render_light_target(VS_DATA_PARAM(vs_vec4, medium_data)
                                                    VS_DATA_PARAM(vs_vec4, light_data)
                                                        vs_render_ray_info ray,
                                                int light, pnanovdb_vec3_t mid, float g)
{
    vs_render_target u;
    u.origin = mid;
    u.dir = ray.dir;
    u.tmax = VS_T_INFINITE;
    u.phase = 0.0f;
    u.falloff = 1.0f;
    pnanovdb_vec3_t at = vs_light_index(VS_DATA_ARG(light_data) light);
    pnanovdb_vec3_t world = vs_light_world(VS_DATA_ARG(light_data) light);
    u.color = vs_light_color(VS_DATA_ARG(light_data) light);
    if (vs_light_type(VS_DATA_ARG(light_data) light) == VS_LIGHT_SUN) {
        u.dir = at;
        u.phase = vs_hg_dirs(g, world, ray.wo);
    } else {
        vs_point_view v =
            vs_point_light_view(VS_DATA_ARG(medium_data) VS_DATA_ARG(light_data) light, mid);
        pnanovdb_vec3_t d = v.offset;
        pnanovdb_vec3_t w = v.world;
        float r = v.distance;
        u.falloff = v.falloff;
        /* A light exactly at the midpoint has no direction: isotropic, unshadowed. */
        u.dir = vs_vec3(1.0f, 0.0f, 0.0f);
        u.tmax = 0.0f;
        u.phase = VS_INV_4PI;
        if (r > 0.0f) {
            u.dir = vs_vec3_scale(d, 1.0f / r);
            u.tmax = r;
            u.phase = vs_hg_dirs(g, vs_vec3_scale(w, -1.0f / r), ray.wo);
        }
    }
    return u;
}

/* Toward sky ordinate `sky` from the segment's midpoint. */
VS_FUNC vs_render_target vs_render_sky_target(VS_DATA_PARAM(vs_vec4, light_data)
                                                  vs_render_ray_info ray,
                                              int sky, pnanovdb_vec3_t mid, float g)
{
    vs_render_target u;
    u.origin = mid;
    u.dir = vs_ordinate_index(VS_DATA_ARG(light_data) sky);
    u.tmax = VS_T_INFINITE;
    u.phase =
        vs_hg_dirs(g, vs_vec3_scale(vs_ordinate_world(VS_DATA_ARG(light_data) sky), -1.0f), ray.wo);
    u.falloff = 1.0f;
    u.color = vs_ordinate_weighted(VS_DATA_ARG(light_data) sky);
    return u;
}

/* Unit 0 marches the camera segment [a, b]; the others march from its midpoint toward
 * direct light unit - 1, then toward the sky ordinates. */
VS_FUNC vs_render_target vs_render_unit_target(VS_DATA_PARAM(vs_vec4, medium_data)
                                                   VS_DATA_PARAM(vs_vec4, light_data)
                                                       vs_render_ray_info ray,
                                               int unit, int light_count, float a, float b,
                                               pnanovdb_vec3_t mid)
{
    float g = vs_medium_g(VS_DATA_ONLY_ARG(medium_data));
    if (unit - 1 >= light_count)
        return vs_render_sky_target(VS_DATA_ARG(light_data) ray, unit - 1 - light_count, mid, g);
    if (unit > 0)
        return vs_render_light_target(VS_DATA_ARG(medium_data) VS_DATA_ARG(light_data) ray,
                                      unit - 1, mid, g);
    vs_render_target u;
    u.origin = vs_vec3_madd(ray.origin, ray.dir, a);
    u.dir = ray.dir;
    u.tmax = b - a;
    u.phase = 0.0f;
    u.falloff = 1.0f;
    u.color = vs_vec3(0.0f, 0.0f, 0.0f);
    return u;
}

/* Grid `grid` of the light-grid set, of kind VS_LGRID_VOXEL: the stored depth at index point
 * p, trilinear in the grid's own index space (the background 0 outside its stored voxels,
 * which cover everywhere a lookup near the density lands). */
VS_FUNC float vs_render_stored_depth(VS_DATA_PARAM(vs_vec4, medium_data)
                                         VS_DATA_PARAM(vs_uint, lgrid_data) pnanovdb_buf_t buf,
                                     int grid, pnanovdb_vec3_t p)
{
    vs_uint unit = vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_VOXEL_GRID);
#if defined(PNANOVDB_GLSL)
    pnanovdb_address_t address = pnanovdb_address_offset(pnanovdb_address_null(), unit * 32u);
#else
    pnanovdb_address_t address =
        pnanovdb_address_offset64(pnanovdb_address_null(), (uint64_t)unit * 32u);
#endif
    pnanovdb_readaccessor_t acc = vs_grid_accessor(buf, address);
    pnanovdb_vec3_t g;
    if (vs_lgrid_word(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_KIND) == VS_LGRID_VOXEL_RADIAL) {
        g = vs_lgrid_radial_coords(VS_DATA_ARG(medium_data) VS_DATA_ARG(lgrid_data) grid, p);
        if (g.z < 0.0f)
            return 0.0f;
    } else {
        pnanovdb_vec3_t t = vs_lgrid_vec3(VS_DATA_ARG(lgrid_data) grid, VS_LGRID_OFF_ORIGIN);
        g = vs_vec3(vs_lgrid_coordinate(VS_DATA_ARG(lgrid_data) grid, 0, p) + t.x,
                    vs_lgrid_coordinate(VS_DATA_ARG(lgrid_data) grid, 1, p) + t.y,
                    vs_lgrid_coordinate(VS_DATA_ARG(lgrid_data) grid, 2, p) + t.z);
    }
    return vs_density_at(buf, PNANOVDB_REF(acc), g);
}

/* The unit's optical depth: toward a light, a lookup in its light grid (or its stored depth)
 * when the render table has light grids; else the unit's one march. */
VS_FUNC vs_accum vs_render_unit_depth(VS_DATA_PARAM(vs_vec4, medium_data)
                                          VS_DATA_PARAM(vs_vec4, render_data)
                                              VS_DATA_PARAM(vs_uint, lgrid_data) pnanovdb_buf_t buf,
                                      PNANOVDB_INOUT(vs_render_accessors) accs, int unit,
                                      pnanovdb_vec3_t mid, vs_render_target u)
{
    vs_accum depth;
    if (unit > 0 && render_data[VS_RENDER_OFF_MARCH].z != 0.0f) {
        vs_accum_init(PNANOVDB_REF(depth));
        float d =
            vs_lgrid_word(VS_DATA_ARG(lgrid_data) unit - 1, VS_LGRID_OFF_KIND) >= VS_LGRID_VOXEL
                ? vs_render_stored_depth(VS_DATA_ARG(medium_data) VS_DATA_ARG(lgrid_data) buf,
                                         unit - 1, mid)
                : vs_lgrid_depth(VS_DATA_ARG(medium_data) VS_DATA_ARG(lgrid_data) unit - 1, mid);
        vs_accum_add(PNANOVDB_REF(depth), d);
    } else {
        depth = vs_march(buf, PNANOVDB_REF(PNANOVDB_DEREF(accs).density), u.origin, u.dir, u.tmax,
                         vs_medium_box_lo(VS_DATA_ONLY_ARG(medium_data)),
                         vs_medium_box_hi(VS_DATA_ONLY_ARG(medium_data)),
                         vs_medium_density_scale(VS_DATA_ONLY_ARG(medium_data)));
    }
    return depth;
}

/* Unit 0's result, the camera segment of optical depth `depth`: the transmittance on to its
 * end, its weight T_a - T_b and its Sms at the midpoint. Returns 0 when the segment was
 * passed over (empty, or another pixel's phase): then the ray has moved on to the next. */
VS_FUNC int vs_render_camera_segment(VS_DATA_PARAM(vs_vec4, render_data) pnanovdb_buf_t buf,
                                     PNANOVDB_INOUT(vs_render_accessors) accs,
                                     vs_render_ray_info ray, PNANOVDB_INOUT(vs_render_state) st,
                                     vs_accum depth, pnanovdb_vec3_t mid)
{
    float tau = vs_accum_value(depth);
    if (!(tau > 0.0f)) {
        vs_render_next_segment(ray, st);
        return 0;
    }
    /* T_a - T_b = T_a (1 - exp(-tau)), accurate for thin segments too. */
    float w = PNANOVDB_DEREF(st).transmittance * vs_one_minus_exp_neg(tau);
    vs_accum_add(PNANOVDB_REF(PNANOVDB_DEREF(st).tau), tau);
    if (vs_accum_value(PNANOVDB_DEREF(st).tau) > VS_TAU_LIMIT) {
        PNANOVDB_DEREF(st).transmittance = 0.0f;
        PNANOVDB_DEREF(st).stop = 1;
    } else {
        PNANOVDB_DEREF(st).transmittance = vs_accum_exp_neg(PNANOVDB_DEREF(st).tau);
    }
    if (!(w > 0.0f) || PNANOVDB_DEREF(st).seg % ray.phases != ray.phase) {
        vs_render_next_segment(ray, st);
        return 0;
    }
    PNANOVDB_DEREF(st).weight = w * VS_FLOAT(ray.phases);
    PNANOVDB_DEREF(st).source = render_data[VS_RENDER_OFF_MARCH].y != 0.0f
                                    ? vs_render_ms(buf, accs, mid, ray.wo)
                                    : vs_vec3(0.0f, 0.0f, 0.0f);
    return 1;
}

/* The light of a unit toward a light or sky ordinate added to S: through the medium and,
 * for a direct light, past the solid occluders (no shadow table: visible) seen from the
 * midpoint of the segment [a, b]. */
VS_FUNC void vs_render_light_arrives(VS_DATA_PARAM(float, shadow_data) vs_render_ray_info ray,
                                     PNANOVDB_INOUT(vs_render_state) st, vs_render_target u,
                                     vs_accum depth, int light, int light_count, float a, float b)
{
    float transmittance = vs_accum_exp_neg(depth);
    if (light < light_count)
        transmittance *=
            vs_shadow_visibility(VS_DATA_ARG(shadow_data) light,
                                 vs_vec3_madd(ray.world_origin, ray.wo, -0.5f * (a + b)));
    PNANOVDB_DEREF(st).source =
        vs_vec3_madd(PNANOVDB_DEREF(st).source, u.color, transmittance * u.phase * u.falloff);
}

/* The segment's S is complete: its light scattered toward the camera joins the radiance. */
VS_FUNC void vs_render_segment_end(VS_DATA_PARAM(vs_vec4, medium_data) vs_render_ray_info ray,
                                   PNANOVDB_INOUT(vs_render_state) st)
{
    pnanovdb_vec3_t s = PNANOVDB_DEREF(st).source;
    pnanovdb_vec3_t albedo = vs_medium_albedo(VS_DATA_ONLY_ARG(medium_data));
    float w = PNANOVDB_DEREF(st).weight;
    PNANOVDB_DEREF(st).radiance = vs_vec3(PNANOVDB_DEREF(st).radiance.x + albedo.x * s.x * w,
                                          PNANOVDB_DEREF(st).radiance.y + albedo.y * s.y * w,
                                          PNANOVDB_DEREF(st).radiance.z + albedo.z * s.z * w);
    vs_render_next_segment(ray, st);
}

/* One unit of work, which always marches exactly once through one call site: the camera
 * segment (unit 0; it also samples Sms), or the transmittance toward one light or sky
 * ordinate from the segment's midpoint. Keeping one march per unit bounds the loop
 * iterations a unit can take (vs_pass.h). */
VS_FUNC void vs_render_unit(VS_RENDER_TABLES pnanovdb_buf_t buf,
                            PNANOVDB_INOUT(vs_render_accessors) accs, vs_render_ray_info ray,
                            PNANOVDB_INOUT(vs_render_state) st)
{
    VS_UNUSED(env_data);      /* read by vs_render_result */
    VS_UNUSED(backdrop_data); /* read by vs_render_camera_ray */
    /* Without S1 (the viewer's "multiple only") the units toward the lights are skipped. */
    int with_s1 = render_data[VS_RENDER_OFF_VIEW].y != 0.0f ? 1 : 0;
    int light_count = with_s1 * vs_lights_direct_count(VS_DATA_ONLY_ARG(light_data));
    int sky_count = with_s1 * vs_lights_ordinate_count(VS_DATA_ONLY_ARG(light_data));
    int seg = PNANOVDB_DEREF(st).seg;
    int unit = PNANOVDB_DEREF(st).unit;
    VS_PRECISE float a = vs_render_segment_at(ray, seg);
    VS_PRECISE float b = vs_render_segment_at(ray, seg + 1);
    pnanovdb_vec3_t mid = vs_vec3_madd(ray.origin, ray.dir, 0.5f * (a + b));

    vs_render_target u = vs_render_unit_target(VS_DATA_ARG(medium_data) VS_DATA_ARG(light_data) ray,
                                               unit, light_count, a, b, mid);
    vs_accum depth = vs_render_unit_depth(VS_DATA_ARG(medium_data) VS_DATA_ARG(render_data)
                                              VS_DATA_ARG(lgrid_data) buf,
                                          accs, unit, mid, u);
    if (unit == 0) {
        if (vs_render_camera_segment(VS_DATA_ARG(render_data) buf, accs, ray, st, depth, mid) == 0)
            return;
    } else {
        vs_render_light_arrives(VS_DATA_ARG(shadow_data) ray, st, u, depth, unit - 1, light_count,
                                a, b);
    }
    PNANOVDB_DEREF(st).unit = unit + 1;
    if (unit + 1 > light_count + sky_count)
        vs_render_segment_end(VS_DATA_ARG(medium_data) ray, st);
}

/* Runs up to max_units units (fewer when the ray is done). */
VS_FUNC void vs_render_advance(VS_RENDER_TABLES pnanovdb_buf_t buf,
                               PNANOVDB_INOUT(vs_render_accessors) accs, vs_render_ray_info ray,
                               PNANOVDB_INOUT(vs_render_state) st, int max_units)
{
    for (int u = 0; u < max_units; ++u) {
        if (PNANOVDB_DEREF(st).stop == 2)
            break;
        vs_render_unit(VS_RENDER_TABLES_ARG buf, accs, ray, st);
    }
}

/* The ray's radiance: the in-scattered integral plus the background seen through it (the
 * constant env colours and the map along the ray). */
VS_FUNC pnanovdb_vec3_t vs_render_result(VS_DATA_PARAM(vs_vec4, light_data)
                                             VS_DATA_PARAM(float, env_data) vs_render_ray_info ray,
                                         vs_render_state st)
{
    if (ray.backdrop != 0)
        return vs_vec3_madd(st.radiance, ray.backdrop_colour, st.transmittance);
    pnanovdb_vec3_t sky = vs_lights_background(VS_DATA_ONLY_ARG(light_data));
    pnanovdb_vec3_t map = vs_env_radiance(VS_DATA_ARG(env_data) vs_vec3_scale(ray.wo, -1.0f));
    return vs_vec3_madd(st.radiance, vs_vec3(sky.x + map.x, sky.y + map.y, sky.z + map.z),
                        st.transmittance);
}

/* Whole-ray and whole-pixel forms (C path, viewer): all units in one go. */
VS_FUNC pnanovdb_vec3_t vs_render_ray(VS_RENDER_TABLES pnanovdb_buf_t buf,
                                      PNANOVDB_INOUT(vs_render_accessors) accs,
                                      pnanovdb_vec3_t origin, pnanovdb_vec3_t dir,
                                      pnanovdb_vec3_t wo)
{
    vs_render_ray_info ray = vs_render_ray_begin(
        VS_DATA_ARG(medium_data) VS_DATA_ARG(render_data) origin, dir, wo, VS_T_INFINITE);
    vs_render_state st = vs_render_state_init(ray);
    vs_render_advance(VS_RENDER_TABLES_ARG buf, accs, ray, PNANOVDB_REF(st), 2147483647);
    return vs_render_result(VS_DATA_ARG(light_data) VS_DATA_ARG(env_data) ray, st);
}

VS_FUNC pnanovdb_vec3_t vs_render_pixel(VS_RENDER_TABLES pnanovdb_buf_t buf,
                                        PNANOVDB_INOUT(vs_render_accessors) accs, int px, int py)
{
    vs_render_ray_info ray = vs_render_camera_ray(
        VS_DATA_ARG(medium_data) VS_DATA_ARG(render_data) VS_DATA_ARG(backdrop_data) px, py);
    vs_render_state st = vs_render_state_init(ray);
    vs_render_advance(VS_RENDER_TABLES_ARG buf, accs, ray, PNANOVDB_REF(st), 2147483647);
    return vs_render_result(VS_DATA_ARG(light_data) VS_DATA_ARG(env_data) ray, st);
}

#if defined(PNANOVDB_GLSL)
/* The state buffers of render_march.comp (vs_pass.h ping-pong): state_in / state_out. */
vs_render_state vs_render_state_load(uint item)
{
    uint s = VS_RENDER_STATE_WORDS * item;
    vs_render_state st;
    st.seg = int(state_in[s + VS_RENDER_STATE_SEG]);
    st.unit = int(state_in[s + VS_RENDER_STATE_UNIT]);
    st.stop = int(state_in[s + VS_RENDER_STATE_STOP]);
    st.tau.sum = uintBitsToFloat(state_in[s + VS_RENDER_STATE_TAU_SUM]);
    st.tau.carry = uintBitsToFloat(state_in[s + VS_RENDER_STATE_TAU_CARRY]);
    st.transmittance = uintBitsToFloat(state_in[s + VS_RENDER_STATE_TRANSMITTANCE]);
    st.weight = uintBitsToFloat(state_in[s + VS_RENDER_STATE_WEIGHT]);
    for (uint c = 0u; c < 3u; ++c) {
        st.source[c] = uintBitsToFloat(state_in[s + VS_RENDER_STATE_SOURCE + c]);
        st.radiance[c] = uintBitsToFloat(state_in[s + VS_RENDER_STATE_RADIANCE + c]);
    }
    return st;
}

void vs_render_state_store(uint item, vs_render_state st)
{
    uint s = VS_RENDER_STATE_WORDS * item;
    state_out[s + VS_RENDER_STATE_SEG] = uint(st.seg);
    state_out[s + VS_RENDER_STATE_UNIT] = uint(st.unit);
    state_out[s + VS_RENDER_STATE_STOP] = uint(st.stop);
    state_out[s + VS_RENDER_STATE_TAU_SUM] = floatBitsToUint(st.tau.sum);
    state_out[s + VS_RENDER_STATE_TAU_CARRY] = floatBitsToUint(st.tau.carry);
    state_out[s + VS_RENDER_STATE_TRANSMITTANCE] = floatBitsToUint(st.transmittance);
    state_out[s + VS_RENDER_STATE_WEIGHT] = floatBitsToUint(st.weight);
    for (uint c = 0u; c < 3u; ++c) {
        state_out[s + VS_RENDER_STATE_SOURCE + c] = floatBitsToUint(st.source[c]);
        state_out[s + VS_RENDER_STATE_RADIANCE + c] = floatBitsToUint(st.radiance[c]);
    }
}
#endif

#endif
