/* Occluder meshes: a strict Wavefront OBJ reader (every malformed line is an error naming
 * file and line; docs/design.md "Decisions" says why not assimp) and tessellated primitives. */
#include "vdbscatter/mesh.h"
#include "vdbscatter/readfile.h"

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define OBJ_FILE_MAX (1024L * 1024 * 1024) /* 1 GiB of text: far beyond any occluder */
#define SPHERE_SEGMENTS_DEFAULT 48
#define SPHERE_SEGMENTS_MAX 4096
#define PLANE_HALF_SIZE_DEFAULT 1000.0

static const double pi = 3.14159265358979323846;

void vdbs_mesh_free(vdbs_mesh *mesh)
{
    if (!mesh)
        return;
    free(mesh->positions);
    free(mesh->normals);
    memset(mesh, 0, sizeof *mesh);
}

/* ---- small vector helpers ---- */

static void sub3(const double a[3], const double b[3], double out[3])
{
    for (int i = 0; i < 3; ++i)
        out[i] = a[i] - b[i];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Normalises v in place; false (v untouched) when it has no direction. */
static bool normalise3(double v[3])
{
    double n = sqrt(dot3(v, v));
    if (!(n > 0.0) || !isfinite(n))
        return false;
    for (int i = 0; i < 3; ++i)
        v[i] /= n;
    return true;
}

/* ---- triangle accumulation ---- */

/* A mesh under construction: capacity in triangles. */
typedef struct mesh_builder {
    vdbs_mesh mesh;
    size_t capacity;
} mesh_builder;

static bool builder_reserve(mesh_builder *b, size_t triangles)
{
    if (triangles <= b->capacity)
        return true;
    if (triangles > (size_t)INT_MAX)
        return false;
    size_t cap = b->capacity ? b->capacity : 64;
    while (cap < triangles)
        cap = cap > (size_t)INT_MAX / 2 ? (size_t)INT_MAX : cap * 2;
    float *p = realloc(b->mesh.positions, cap * 9 * sizeof *p);
    if (!p)
        return false;
    b->mesh.positions = p;
    float *n = realloc(b->mesh.normals, cap * 9 * sizeof *n);
    if (!n)
        return false;
    b->mesh.normals = n;
    b->capacity = cap;
    return true;
}

/* Appends a triangle; a corner's normal is normals[k] when given and non-zero, else the
 * face normal. Zero-area triangles are dropped (they draw nothing and have no normal).
 * False only when out of memory. */
static bool builder_add(mesh_builder *b, double p[3][3], const double *const normals[3])
{
    double e1[3], e2[3], face[3];
    sub3(p[1], p[0], e1);
    sub3(p[2], p[0], e2);
    cross3(e1, e2, face);
    if (!normalise3(face))
        return true;
    if (!builder_reserve(b, (size_t)b->mesh.triangle_count + 1))
        return false;
    float *pos = b->mesh.positions + 9 * (size_t)b->mesh.triangle_count;
    float *nor = b->mesh.normals + 9 * (size_t)b->mesh.triangle_count;
    for (int k = 0; k < 3; ++k) {
        double n[3] = {face[0], face[1], face[2]};
        if (normals && normals[k]) {
            double g[3] = {normals[k][0], normals[k][1], normals[k][2]};
            if (normalise3(g))
                memcpy(n, g, sizeof n);
        }
        for (int i = 0; i < 3; ++i) {
            pos[3 * k + i] = (float)p[k][i];
            nor[3 * k + i] = (float)n[i];
        }
    }
    b->mesh.triangle_count++;
    return true;
}

static vdbs_status builder_finish(mesh_builder *b, vdbs_mesh *out)
{
    *out = b->mesh;
    return VDBS_OK;
}

static vdbs_status builder_nomem(mesh_builder *b, const char *what, vdbs_error *err)
{
    vdbs_mesh_free(&b->mesh);
    return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory", what);
}

/* ---- OBJ ---- */

/* The transform as matrices: positions by M = R S, normals by R S^-1 (the inverse
 * transpose of M, as R is orthonormal and S diagonal). */
typedef struct obj_placement {
    double translate[3];
    double m[3][3];
    double n[3][3];
} obj_placement;

static void placement_init(const vdbs_mesh_transform *t, obj_placement *pl)
{
    double scale[3] = {1.0, 1.0, 1.0}, r[3][3];
    memset(pl, 0, sizeof *pl);
    if (t) {
        memcpy(pl->translate, t->translate, sizeof pl->translate);
        for (int i = 0; i < 3; ++i)
            if (t->scale[i] != 0.0)
                scale[i] = t->scale[i];
    }
    double a[3] = {0.0, 0.0, 0.0};
    for (int i = 0; t && i < 3; ++i)
        a[i] = t->rotate_deg[i] * pi / 180.0;
    double cx = cos(a[0]), sx = sin(a[0]), cy = cos(a[1]), sy = sin(a[1]);
    double cz = cos(a[2]), sz = sin(a[2]);
    /* R = Rz Ry Rx */
    r[0][0] = cz * cy;
    r[0][1] = cz * sy * sx - sz * cx;
    r[0][2] = cz * sy * cx + sz * sx;
    r[1][0] = sz * cy;
    r[1][1] = sz * sy * sx + cz * cx;
    r[1][2] = sz * sy * cx - cz * sx;
    r[2][0] = -sy;
    r[2][1] = cy * sx;
    r[2][2] = cy * cx;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            pl->m[i][j] = r[i][j] * scale[j];
            pl->n[i][j] = r[i][j] / scale[j];
        }
}

static void apply3(double m[3][3], const double v[3], double out[3])
{
    for (int i = 0; i < 3; ++i)
        out[i] = m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2];
}

/* A growable array of 3-vectors (OBJ v and vn). */
typedef struct vec3_list {
    double (*v)[3];
    size_t count, capacity;
} vec3_list;

static bool vec3_push(vec3_list *l, const double v[3])
{
    if (l->count == l->capacity) {
        size_t cap = l->capacity ? l->capacity * 2 : 256;
        if (cap > (size_t)INT_MAX)
            return false;
        double(*n)[3] = realloc(l->v, cap * sizeof *n);
        if (!n)
            return false;
        l->v = n;
        l->capacity = cap;
    }
    memcpy(l->v[l->count++], v, sizeof l->v[0]);
    return true;
}

/* One corner of a face: indices into v and vn (vn -1 when absent). */
typedef struct obj_corner {
    long v, vn;
} obj_corner;

typedef struct obj_reader {
    const char *path;
    long line;
    vdbs_error *err;
    vec3_list v, vn;
    size_t vt_count;
    obj_corner *corners; /* of the current face */
    size_t corner_capacity;
    size_t face_count;
    obj_placement placement;
    mesh_builder out;
} obj_reader;

static vdbs_status obj_fail(const obj_reader *r, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static vdbs_status obj_fail(const obj_reader *r, const char *fmt, ...)
{
    char msg[VDBS_ERROR_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return vdbs_error_set(r->err, VDBS_ERR_INPUT, "%s:%ld: %s", r->path, r->line, msg);
}

static bool is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

static char *skip_space(char *s)
{
    while (is_space(*s))
        ++s;
    return s;
}

/* The next whitespace-separated token of *s (NUL-terminated in place), or NULL at the
 * end of the line. */
static char *next_token(char **s)
{
    char *p = skip_space(*s);
    if (!*p)
        return NULL;
    char *end = p;
    while (*end && !is_space(*end))
        ++end;
    if (*end)
        *end++ = '\0';
    *s = end;
    return p;
}

/* The numbers of a v / vn / vt line: between lo and hi of them, each finite. */
static vdbs_status read_numbers(obj_reader *r, const char *key, char *rest, int lo, int hi,
                                double *out, int *count)
{
    int n = 0;
    for (char *tok; (tok = next_token(&rest));) {
        if (n == hi)
            return obj_fail(r, "%s: more than %d numbers", key, hi);
        char *end = NULL;
        errno = 0;
        double x = strtod(tok, &end);
        if (end == tok || *end != '\0')
            return obj_fail(r, "%s: '%s' is not a number", key, tok);
        if (errno == ERANGE && fabs(x) > 1.0)
            return obj_fail(r, "%s: '%s' overflows a double", key, tok);
        if (!isfinite(x))
            return obj_fail(r, "%s: '%s' is not a finite number", key, tok);
        /* Positions are kept as floats: a larger double would become infinite there. */
        if (fabs(x) > FLT_MAX)
            return obj_fail(r, "%s: '%s' is beyond a float's range", key, tok);
        out[n++] = x;
    }
    if (n < lo)
        return obj_fail(r, "%s: expected %s%d numbers, got %d", key, lo == hi ? "" : "at least ",
                        lo, n);
    *count = n;
    return VDBS_OK;
}

/* One index of a face corner: a non-zero decimal integer; negative counts back from the
 * last element defined so far. Returns the 0-based index or fails. */
static vdbs_status read_index(obj_reader *r, const char *text, size_t len, const char *what,
                              size_t defined, const char *corner, long *out)
{
    char buf[32];
    if (len == 0 || len >= sizeof buf)
        return obj_fail(r, "f: corner '%s': %s index %s", corner, what,
                        len == 0 ? "missing" : "too long");
    memcpy(buf, text, len);
    buf[len] = '\0';
    char *end = NULL;
    errno = 0;
    long i = strtol(buf, &end, 10);
    if (end == buf || *end != '\0' || (buf[0] == '+') || errno == ERANGE)
        return obj_fail(r, "f: corner '%s': %s index '%s' is not an integer", corner, what, buf);
    if (i == 0)
        return obj_fail(r, "f: corner '%s': %s index 0 (OBJ indices start at 1)", corner, what);
    long resolved = i > 0 ? i - 1 : (long)defined + i;
    if (resolved < 0 || (size_t)resolved >= defined)
        return obj_fail(r, "f: corner '%s': %s index %ld out of range (%zu defined so far)", corner,
                        what, i, defined);
    *out = resolved;
    return VDBS_OK;
}

/* "v", "v/vt", "v//vn" or "v/vt/vn". */
static vdbs_status read_corner(obj_reader *r, const char *tok, obj_corner *c)
{
    const char *s1 = strchr(tok, '/');
    const char *s2 = s1 ? strchr(s1 + 1, '/') : NULL;
    vdbs_status st;
    long vt = 0;
    if (s2 && strchr(s2 + 1, '/'))
        return obj_fail(r, "f: corner '%s': more than 3 indices", tok);
    size_t vlen = s1 ? (size_t)(s1 - tok) : strlen(tok);
    if ((st = read_index(r, tok, vlen, "vertex", r->v.count, tok, &c->v)) != VDBS_OK)
        return st;
    c->vn = -1;
    if (!s1)
        return VDBS_OK;
    size_t tlen = s2 ? (size_t)(s2 - s1 - 1) : strlen(s1 + 1);
    /* v/vt needs its vt; in v//vn the middle one is empty. */
    if ((tlen > 0 || !s2) &&
        (st = read_index(r, s1 + 1, tlen, "texture", r->vt_count, tok, &vt)) != VDBS_OK)
        return st;
    if (s2 &&
        (st = read_index(r, s2 + 1, strlen(s2 + 1), "normal", r->vn.count, tok, &c->vn)) != VDBS_OK)
        return st;
    return VDBS_OK;
}

static vdbs_status read_face(obj_reader *r, char *rest)
{
    size_t n = 0;
    vdbs_status st;
    for (char *tok; (tok = next_token(&rest));) {
        if (n == r->corner_capacity) {
            size_t cap = r->corner_capacity ? r->corner_capacity * 2 : 16;
            obj_corner *c = realloc(r->corners, cap * sizeof *c);
            if (!c)
                return vdbs_error_set(r->err, VDBS_ERR_NOMEM, "%s: out of memory", r->path);
            r->corners = c;
            r->corner_capacity = cap;
        }
        if ((st = read_corner(r, tok, &r->corners[n])) != VDBS_OK)
            return st;
        ++n;
    }
    if (n < 3)
        return obj_fail(r, "f: a face needs at least 3 corners, got %zu", n);
    ++r->face_count;
    /* Fan triangulation: exact for the convex polygons OBJ exporters write. */
    for (size_t k = 1; k + 1 < n; ++k) {
        const obj_corner *c[3] = {&r->corners[0], &r->corners[k], &r->corners[k + 1]};
        double p[3][3], nbuf[3][3];
        const double *normals[3] = {NULL, NULL, NULL};
        for (int j = 0; j < 3; ++j) {
            double q[3];
            apply3(r->placement.m, r->v.v[c[j]->v], q);
            for (int i = 0; i < 3; ++i)
                p[j][i] = q[i] + r->placement.translate[i];
            if (c[j]->vn >= 0) {
                apply3(r->placement.n, r->vn.v[c[j]->vn], nbuf[j]);
                normals[j] = nbuf[j];
            }
        }
        if (!builder_add(&r->out, p, normals))
            return vdbs_error_set(r->err, VDBS_ERR_NOMEM, "%s: out of memory", r->path);
    }
    return VDBS_OK;
}

static vdbs_status read_line(obj_reader *r, char *line)
{
    char *hash = strchr(line, '#');
    if (hash)
        *hash = '\0';
    char *rest = line;
    char *key = next_token(&rest);
    double x[6];
    int n = 0;
    vdbs_status st;
    if (!key)
        return VDBS_OK;
    if (strcmp(key, "v") == 0) {
        if ((st = read_numbers(r, "v", rest, 3, 6, x, &n)) != VDBS_OK)
            return st;
        /* x y z, x y z w, or x y z r g b (a common vertex-colour extension) */
        if (n == 5)
            return obj_fail(r, "v: expected 3, 4 or 6 numbers (x y z [w | r g b]), got %d", n);
        if (!vec3_push(&r->v, x))
            return vdbs_error_set(r->err, VDBS_ERR_NOMEM, "%s: out of memory", r->path);
    } else if (strcmp(key, "vn") == 0) {
        if ((st = read_numbers(r, "vn", rest, 3, 3, x, &n)) != VDBS_OK)
            return st;
        if (!vec3_push(&r->vn, x))
            return vdbs_error_set(r->err, VDBS_ERR_NOMEM, "%s: out of memory", r->path);
    } else if (strcmp(key, "vt") == 0) {
        if ((st = read_numbers(r, "vt", rest, 1, 3, x, &n)) != VDBS_OK)
            return st;
        ++r->vt_count;
    } else if (strcmp(key, "f") == 0) {
        return read_face(r, rest);
    } else if (strcmp(key, "o") == 0 || strcmp(key, "g") == 0 || strcmp(key, "s") == 0 ||
               strcmp(key, "usemtl") == 0 || strcmp(key, "mtllib") == 0) {
        /* names, smoothing groups and materials: nothing an occluder uses */
    } else {
        return obj_fail(r,
                        "unsupported statement '%.40s' (expected v, vt, vn, f, o, g, s, usemtl, "
                        "mtllib or a comment)",
                        key);
    }
    return VDBS_OK;
}

vdbs_status vdbs_mesh_load_obj(const char *path, const vdbs_mesh_transform *transform,
                               vdbs_mesh *out, vdbs_error *err)
{
    char *text = NULL;
    size_t len = 0;
    vdbs_status st;
    if (!path || !out) /* a caller's mistake */
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "mesh: no OBJ path or output given");
    if ((st = vdbs_read_file(path, NULL, OBJ_FILE_MAX, &text, &len, err)) != VDBS_OK)
        return st;
    obj_reader r = {0};
    r.path = path;
    r.err = err;
    placement_init(transform, &r.placement);
    st = VDBS_OK;
    char *p = text, *end = text + len;
    while (st == VDBS_OK && p < end) {
        char *nl = memchr(p, '\n', (size_t)(end - p));
        char *line_end = nl ? nl : end;
        ++r.line;
        /* A NUL inside a line: a binary file, not text that strtod could misread. */
        if (memchr(p, '\0', (size_t)(line_end - p))) {
            st = obj_fail(&r, "not a text file (NUL byte)");
            break;
        }
        *line_end = '\0';
        st = read_line(&r, p);
        p = line_end + 1;
    }
    if (st == VDBS_OK && r.face_count == 0)
        st =
            vdbs_error_set(err, VDBS_ERR_INPUT, "%s: no faces (an occluder needs triangles)", path);
    else if (st == VDBS_OK && r.out.mesh.triangle_count == 0)
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s: every face has zero area", path);
    free(text);
    free(r.v.v);
    free(r.vn.v);
    free(r.corners);
    if (st != VDBS_OK) {
        vdbs_mesh_free(&r.out.mesh);
        return st;
    }
    return builder_finish(&r.out, out);
}

/* ---- primitives ---- */

/* Unit direction of stack boundary j (0 at +Y) and slice boundary i; the poles exact, so
 * that the triangles around them close without slivers. */
static void sphere_direction(int j, int i, int stacks, int segments, double d[3])
{
    if (j == 0 || j == stacks) {
        d[0] = d[2] = 0.0;
        d[1] = j == 0 ? 1.0 : -1.0;
        return;
    }
    double theta = pi * (double)j / stacks, phi = 2.0 * pi * (double)i / segments;
    d[0] = sin(theta) * cos(phi);
    d[1] = cos(theta);
    d[2] = -sin(theta) * sin(phi);
}

vdbs_status vdbs_mesh_sphere(const double center[3], double radius, int segments, vdbs_mesh *out,
                             vdbs_error *err)
{
    if (!(isfinite(radius) && radius > 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "mesh: sphere radius must be > 0, got %g",
                              radius);
    if (segments < 3 || segments > SPHERE_SEGMENTS_MAX)
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "mesh: sphere segments must be in [3, %d], got %d",
                              SPHERE_SEGMENTS_MAX, segments);
    int stacks = segments / 2 < 2 ? 2 : segments / 2;
    mesh_builder b = {0};
    if (!builder_reserve(&b, (size_t)2 * (size_t)segments * (size_t)(stacks - 1)))
        return builder_nomem(&b, "mesh: sphere", err);
    for (int j = 0; j < stacks; ++j)
        for (int i = 0; i < segments; ++i) {
            double d[4][3], p[4][3];
            sphere_direction(j, i, stacks, segments, d[0]);
            sphere_direction(j + 1, i, stacks, segments, d[1]);
            sphere_direction(j + 1, i + 1, stacks, segments, d[2]);
            sphere_direction(j, i + 1, stacks, segments, d[3]);
            for (int k = 0; k < 4; ++k)
                for (int a = 0; a < 3; ++a)
                    p[k][a] = center[a] + radius * d[k][a];
            /* Going down a stack (d0 -> d1) then around (-> d2) winds counter-clockwise
             * seen from outside, with phi increasing toward -Z. */
            double tri_a[3][3] = {{p[0][0], p[0][1], p[0][2]},
                                  {p[1][0], p[1][1], p[1][2]},
                                  {p[2][0], p[2][1], p[2][2]}};
            const double *na[3] = {d[0], d[1], d[2]};
            double tri_b[3][3] = {{p[0][0], p[0][1], p[0][2]},
                                  {p[2][0], p[2][1], p[2][2]},
                                  {p[3][0], p[3][1], p[3][2]}};
            const double *nb[3] = {d[0], d[2], d[3]};
            /* At a pole one of the two triangles is degenerate: builder_add drops it. */
            if (!builder_add(&b, tri_a, na) || !builder_add(&b, tri_b, nb))
                return builder_nomem(&b, "mesh: sphere", err);
        }
    return builder_finish(&b, out);
}

/* Appends the quad a b c d (counter-clockwise seen from its front) as 2 triangles. */
static bool add_quad(mesh_builder *b, const double a[3], const double bb[3], const double c[3],
                     const double d[3])
{
    double t1[3][3] = {{a[0], a[1], a[2]}, {bb[0], bb[1], bb[2]}, {c[0], c[1], c[2]}};
    double t2[3][3] = {{a[0], a[1], a[2]}, {c[0], c[1], c[2]}, {d[0], d[1], d[2]}};
    return builder_add(b, t1, NULL) && builder_add(b, t2, NULL);
}

vdbs_status vdbs_mesh_box(const double min[3], const double max[3], vdbs_mesh *out, vdbs_error *err)
{
    for (int a = 0; a < 3; ++a)
        if (!(isfinite(min[a]) && isfinite(max[a]) && min[a] < max[a]))
            return vdbs_error_set(err, VDBS_ERR_INPUT,
                                  "mesh: box min must be below max on every axis");
    /* Corner k has x from bit 0, y from bit 1, z from bit 2 (0: min, 1: max). */
    double c[8][3];
    for (int k = 0; k < 8; ++k)
        for (int a = 0; a < 3; ++a)
            c[k][a] = (k >> a) & 1 ? max[a] : min[a];
    /* Each face counter-clockwise seen from outside. */
    static const int faces[6][4] = {
        {0, 4, 6, 2}, /* -X */
        {1, 3, 7, 5}, /* +X */
        {0, 1, 5, 4}, /* -Y */
        {2, 6, 7, 3}, /* +Y */
        {0, 2, 3, 1}, /* -Z */
        {4, 5, 7, 6}, /* +Z */
    };
    mesh_builder b = {0};
    for (int f = 0; f < 6; ++f)
        if (!add_quad(&b, c[faces[f][0]], c[faces[f][1]], c[faces[f][2]], c[faces[f][3]]))
            return builder_nomem(&b, "mesh: box", err);
    return builder_finish(&b, out);
}

vdbs_status vdbs_mesh_plane(const double point[3], const double normal[3], const double focus[3],
                            double half_size, vdbs_mesh *out, vdbs_error *err)
{
    double n[3] = {normal[0], normal[1], normal[2]};
    if (!normalise3(n))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "mesh: plane normal must be non-zero");
    if (!(isfinite(half_size) && half_size > 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "mesh: plane half size must be > 0, got %g",
                              half_size);
    /* u, v, n right-handed: u from the axis least aligned with n. */
    double axis[3] = {0.0, 0.0, 0.0}, u[3], v[3];
    int least = fabs(n[0]) <= fabs(n[1]) && fabs(n[0]) <= fabs(n[2]) ? 0
                : fabs(n[1]) <= fabs(n[2])                           ? 1
                                                                     : 2;
    axis[least] = 1.0;
    cross3(axis, n, u);
    normalise3(u);
    cross3(n, u, v);
    double to_focus[3], centre[3], q[4][3];
    sub3(focus, point, to_focus);
    double h = dot3(to_focus, n);
    for (int a = 0; a < 3; ++a)
        centre[a] = focus[a] - h * n[a];
    static const double su[4] = {-1.0, 1.0, 1.0, -1.0}, sv[4] = {-1.0, -1.0, 1.0, 1.0};
    for (int k = 0; k < 4; ++k)
        for (int a = 0; a < 3; ++a)
            q[k][a] = centre[a] + half_size * (su[k] * u[a] + sv[k] * v[a]);
    mesh_builder b = {0};
    if (!add_quad(&b, q[0], q[1], q[2], q[3]))
        return builder_nomem(&b, "mesh: plane", err);
    return builder_finish(&b, out);
}

/* ---- occluders ---- */

vdbs_status vdbs_occluder_mesh(const vdbs_scene *scene, int index,
                               const vdbs_occluder_mesh_desc *desc, vdbs_mesh *out, vdbs_error *err)
{
    if (!scene || index < 0 || index >= scene->occluder_count || index >= VDBS_MAX_OCCLUDERS)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "mesh: no occluder %d in the scene", index);
    const vdbs_occluder_mesh_desc none = {0};
    if (!desc)
        desc = &none;
    const vdbs_occluder *o = &scene->occluders[index];
    switch (o->type) {
    case VDBS_OCCLUDER_OBJ: {
        vdbs_mesh_transform t = {0};
        memcpy(t.translate, o->translate, sizeof t.translate);
        memcpy(t.scale, o->scale, sizeof t.scale);
        memcpy(t.rotate_deg, o->rotate_deg, sizeof t.rotate_deg);
        const char *file = vdbs_occluder_obj_file(scene, o);
        if (!file[0])
            return vdbs_error_set(err, VDBS_ERR_INTERNAL, "mesh: occluder %d has no OBJ path",
                                  index);
        return vdbs_mesh_load_obj(file, &t, out, err);
    }
    case VDBS_OCCLUDER_SPHERE:
        return vdbs_mesh_sphere(
            o->center, o->radius,
            desc->sphere_segments > 0 ? desc->sphere_segments : SPHERE_SEGMENTS_DEFAULT, out, err);
    case VDBS_OCCLUDER_BOX:
        return vdbs_mesh_box(o->min, o->max, out, err);
    case VDBS_OCCLUDER_PLANE:
        return vdbs_mesh_plane(o->point, o->normal, desc->plane_focus,
                               desc->plane_half_size > 0.0 ? desc->plane_half_size
                                                           : PLANE_HALF_SIZE_DEFAULT,
                               out, err);
    }
    return vdbs_error_set(err, VDBS_ERR_INTERNAL, "mesh: occluder %d has invalid type %d", index,
                          (int)o->type);
}

vdbs_status vdbs_occluders_check(const vdbs_scene *scene, vdbs_error *err)
{
    for (int i = 0; i < scene->occluder_count && i < VDBS_MAX_OCCLUDERS; ++i) {
        if (scene->occluders[i].type != VDBS_OCCLUDER_OBJ)
            continue;
        vdbs_mesh mesh = {0};
        vdbs_error inner = {{0}};
        vdbs_status st = vdbs_occluder_mesh(scene, i, NULL, &mesh, &inner);
        vdbs_mesh_free(&mesh);
        if (st != VDBS_OK)
            return vdbs_error_set(err, st, "occluders[%d].file: %s", i, inner.message);
    }
    return VDBS_OK;
}

/* ---- measures ---- */

static void corner(const vdbs_mesh *m, int t, int k, double p[3])
{
    const float *f = m->positions + 9 * (size_t)t + 3 * (size_t)k;
    p[0] = f[0];
    p[1] = f[1];
    p[2] = f[2];
}

double vdbs_mesh_area(const vdbs_mesh *mesh)
{
    double sum = 0.0;
    for (int t = 0; t < mesh->triangle_count; ++t) {
        double a[3], b[3], c[3], e1[3], e2[3], x[3];
        corner(mesh, t, 0, a);
        corner(mesh, t, 1, b);
        corner(mesh, t, 2, c);
        sub3(b, a, e1);
        sub3(c, a, e2);
        cross3(e1, e2, x);
        sum += 0.5 * sqrt(dot3(x, x));
    }
    return sum;
}

double vdbs_mesh_volume(const vdbs_mesh *mesh)
{
    double sum = 0.0;
    for (int t = 0; t < mesh->triangle_count; ++t) {
        double a[3], b[3], c[3], x[3];
        corner(mesh, t, 0, a);
        corner(mesh, t, 1, b);
        corner(mesh, t, 2, c);
        cross3(b, c, x);
        sum += dot3(a, x) / 6.0; /* signed volume of the tetrahedron (origin, a, b, c) */
    }
    return sum;
}

void vdbs_mesh_bounds(const vdbs_mesh *mesh, double min[3], double max[3])
{
    for (int a = 0; a < 3; ++a) {
        min[a] = INFINITY;
        max[a] = -INFINITY;
    }
    for (size_t i = 0; i < 3 * (size_t)mesh->triangle_count; ++i)
        for (int a = 0; a < 3; ++a) {
            double x = mesh->positions[3 * i + (size_t)a];
            min[a] = fmin(min[a], x);
            max[a] = fmax(max[a], x);
        }
}
