/* Occluder meshes: the strict OBJ reader (every accepted form, the transform, and each
 * malformed case naming file and line), the tessellated primitives against their exact
 * area and volume, and the scene's occluders. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/mesh.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"

static const double pi = 3.14159265358979323846;

static void assert_contains(const char *haystack, const char *needle)
{
    if (!strstr(haystack, needle))
        fail_msg("message \"%s\" does not contain \"%s\"", haystack, needle);
}

static void assert_near(double got, double want, double tol, const char *what)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("%s: got %.17g, expected %.17g (tolerance %g)", what, got, want, tol);
}

/* Writes `text` (len bytes) to a file of the test tmp folder; returns its path. */
static const char *write_file(const char *name, const char *text, size_t len)
{
    const char *path = test_tmp_path(name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    fclose(f);
    return path;
}

static const char *write_text(const char *name, const char *text)
{
    return write_file(name, text, strlen(text));
}

/* The cube [-1,1]^3: quads in every corner form the reader accepts, wound outward, with
 * everything the reader ignores around them (CRLF endings too). */
static const char *const cube_obj =
    "# a cube of side 2\r\n"
    "mtllib cube.mtl\n"
    "o Cube\n"
    "\n"
    "v -1 -1 -1\n"
    "v  1 -1 -1\n"
    "v -1  1 -1\n"
    "v  1  1 -1\n"
    "v -1 -1  1 1.0\n" /* with w */
    "v  1 -1  1\n"
    "v -1  1  1 0.5 0.5 0.5\n" /* with a colour */
    "v  1  1  1\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "vn -1 0 0\n"
    "g faces\n"
    "usemtl grey\n"
    "s off\n"
    "f 1//1 5//1 7//1 3//1\n"       /* -X, with normals */
    "f 2/1 4/2 8/3 6/4\n"           /* +X, with texture coordinates */
    "f 1/1/1 2/2/1 6/3/1 5/4/1\r\n" /* -Y: v/vt/vn (the normal is wrong on purpose) */
    "f 3 7 8 4   # +Y, a trailing comment\n"
    "f -8 -6 -5 -7\n" /* -Z with negative indices */
    "f 5 6 8 7";      /* +Z, no final newline */

static void test_obj_cube(void **state)
{
    (void)state;
    vdbs_error err = {{0}};
    vdbs_mesh m = {0};
    const char *path = write_text("test_mesh_cube.obj", cube_obj);
    if (vdbs_mesh_load_obj(path, NULL, &m, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(m.triangle_count, 12);
    double lo[3], hi[3];
    vdbs_mesh_bounds(&m, lo, hi);
    for (int a = 0; a < 3; ++a) {
        assert_true(lo[a] == -1.0);
        assert_true(hi[a] == 1.0);
    }
    assert_near(vdbs_mesh_area(&m), 24.0, 1e-12, "cube area");
    assert_near(vdbs_mesh_volume(&m), 8.0, 1e-12, "cube volume (outward winding)");
    /* the -X face's corners carry the file's normal (-1,0,0); the +Y face has none and gets
     * its face normal */
    for (int t = 0; t < 12; ++t) {
        const float *n = m.normals + 9 * t;
        for (int k = 0; k < 3; ++k) {
            double len = sqrt(n[3 * k] * n[3 * k] + n[3 * k + 1] * n[3 * k + 1] +
                              n[3 * k + 2] * n[3 * k + 2]);
            assert_near(len, 1.0, 1e-6, "unit normal");
        }
    }
    assert_true(m.normals[0] == -1.0f && m.normals[1] == 0.0f && m.normals[2] == 0.0f);
    assert_true(m.normals[9 * 6 + 1] == 1.0f); /* +Y (fourth face: triangles 6 and 7) */
    vdbs_mesh_free(&m);
    assert_null(m.positions);

    /* placed: scaled by (1, 2, 3), turned 90 degrees about Y (x -> -z), moved by (10, 0, 0) */
    vdbs_mesh_transform t = {0};
    t.scale[0] = 1.0;
    t.scale[1] = 2.0;
    t.scale[2] = 3.0;
    t.rotate_deg[1] = 90.0;
    t.translate[0] = 10.0;
    assert_int_equal(vdbs_mesh_load_obj(path, &t, &m, &err), VDBS_OK);
    vdbs_mesh_bounds(&m, lo, hi);
    const double want_lo[3] = {7.0, -2.0, -1.0}, want_hi[3] = {13.0, 2.0, 1.0};
    for (int a = 0; a < 3; ++a) {
        assert_near(lo[a], want_lo[a], 1e-6, "placed bounds min");
        assert_near(hi[a], want_hi[a], 1e-6, "placed bounds max");
    }
    assert_near(vdbs_mesh_volume(&m), 8.0 * 6.0, 1e-4, "placed volume");
    assert_near(vdbs_mesh_area(&m), 8.0 * (1 * 2 + 2 * 3 + 3 * 1), 1e-4, "placed area");
    /* the -X normal turns with the cube: (-1,0,0) -> (0,0,1) under Ry(90) */
    assert_near(m.normals[0], 0.0, 1e-6, "turned normal x");
    assert_near(m.normals[2], 1.0, 1e-6, "turned normal z");
    vdbs_mesh_free(&m);
}

static void test_obj_negative_indices(void **state)
{
    (void)state;
    vdbs_error err = {{0}};
    vdbs_mesh pos = {0}, neg = {0};
    const char *a = write_text("test_mesh_pos.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                                                    "v 0 0 1\nf 1 4 2\n");
    const char *b = write_text("test_mesh_neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                                                    "v 0 0 1\nf -4 -1 -3\n");
    assert_int_equal(vdbs_mesh_load_obj(a, NULL, &pos, &err), VDBS_OK);
    assert_int_equal(vdbs_mesh_load_obj(b, NULL, &neg, &err), VDBS_OK);
    assert_int_equal(pos.triangle_count, 2);
    assert_int_equal(neg.triangle_count, 2);
    assert_memory_equal(pos.positions, neg.positions, 18 * sizeof(float));
    assert_memory_equal(pos.normals, neg.normals, 18 * sizeof(float));
    /* counter-clockwise (0,0,0) (1,0,0) (0,1,0) faces +Z */
    assert_true(pos.normals[2] == 1.0f);
    vdbs_mesh_free(&pos);
    vdbs_mesh_free(&neg);

    /* a pentagon is fanned into 3 triangles, and a zero-area triangle is dropped */
    const char *c = write_text("test_mesh_fan.obj", "v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\n"
                                                    "v -1 1 0\nf 1 2 3 4 5\nf 1 2 1\n");
    assert_int_equal(vdbs_mesh_load_obj(c, NULL, &pos, &err), VDBS_OK);
    assert_int_equal(pos.triangle_count, 3);
    vdbs_mesh_free(&pos);
}

typedef struct bad_obj {
    const char *text;
    int line;           /* 0: the message names the file without a line */
    const char *needle; /* expected part of the message after "PATH:LINE: " */
} bad_obj;

static void test_obj_malformed(void **state)
{
    (void)state;
    static const bad_obj cases[] = {
        {"v 0 0 0\nv abc 0 0\nv 0 1 0\nf 1 2 3\n", 2, "v: 'abc' is not a number"},
        {"v 0 0 0\nv 1,5 0 0\n", 2, "'1,5' is not a number"},
        {"v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", 2, "v: expected at least 3 numbers, got 2"},
        {"v 0 0 0 1 1\n", 1, "v: expected 3, 4 or 6 numbers"},
        {"v 0 0 0 1 1 1 1\n", 1, "v: more than 6 numbers"},
        {"v 1e999 0 0\n", 1, "'1e999'"},
        {"v nan 0 0\n", 1, "'nan' is not a finite number"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", 4, "vertex index 9 out of range (3 defined"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "vertex index 0 (OBJ indices start at 1)"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", 4, "vertex index -4 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "f: a face needs at least 3 corners, got 2"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", 4, "at least 3 corners, got 0"},
        {"f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", 1, "vertex index 1 out of range (0 defined"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", 4, "texture index 1 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1// 2// 3//\n", 4, "normal index missing"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//2 2//1 3//1\n", 5,
         "normal index 2 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2 3\n", 4, "texture index missing"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n", 4, "more than 3 indices"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf a b c\n", 4, "vertex index 'a' is not an integer"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1.5 2 3\n", 4, "is not an integer"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 99999999999999999999999 2 3\n", 4, "not an integer"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n", 4, "unsupported statement 'l'"},
        {"v 0 0 0\nvn 0 1\n", 2, "vn: expected 3 numbers, got 2"},
        {"v 0 0 0\nvt 0 0 0 0\n", 2, "vt: more than 3 numbers"},
        {"v 0 0 0\nvt\n", 2, "vt: expected at least 1 numbers, got 0"},
        /* truncated in the middle of a vertex line */
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1.5 2", 5, "expected at least 3 numbers"},
        /* a file without faces, and one whose only face has no area */
        {"v 0 0 0\nv 1 0 0\n", 0, "no faces"},
        {"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", 0, "every face has zero area"},
        {"", 0, "no faces"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char name[64], want[4200];
        snprintf(name, sizeof name, "test_mesh_bad%zu.obj", i);
        const char *path = write_text(name, cases[i].text);
        vdbs_error err = {{0}};
        vdbs_mesh m = {0};
        vdbs_status st = vdbs_mesh_load_obj(path, NULL, &m, &err);
        if (st != VDBS_ERR_INPUT)
            fail_msg("case %zu (%s): status %d, expected VDBS_ERR_INPUT", i, cases[i].text,
                     (int)st);
        assert_null(m.positions);
        if (cases[i].line)
            snprintf(want, sizeof want, "%s:%d: ", path, cases[i].line);
        else
            snprintf(want, sizeof want, "%s: ", path);
        if (strncmp(err.message, want, strlen(want)) != 0)
            fail_msg("case %zu: message \"%s\" does not start with \"%s\"", i, err.message, want);
        assert_contains(err.message, cases[i].needle);
    }

    /* a binary file: the first line with a NUL byte */
    static const char binary[] = "v 0 0 0\n\x7f"
                                 "ELF\x02\x01\x01\x00\x00\x00\n";
    const char *path = write_file("test_mesh_binary.obj", binary, sizeof binary - 1);
    vdbs_error err = {{0}};
    vdbs_mesh m = {0};
    assert_int_equal(vdbs_mesh_load_obj(path, NULL, &m, &err), VDBS_ERR_INPUT);
    char want[4200];
    snprintf(want, sizeof want, "%s:2: not a text file", path);
    assert_contains(err.message, want);
    /* a text-looking binary line without NUL is an unsupported statement */
    path = write_text("test_mesh_binary2.obj", "\x7f\x45LF garbage\n");
    assert_int_equal(vdbs_mesh_load_obj(path, NULL, &m, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, ":1: unsupported statement");

    /* a missing file and a directory */
    path = test_tmp_path("test_mesh_no_such.obj");
    remove(path);
    assert_int_equal(vdbs_mesh_load_obj(path, NULL, &m, &err), VDBS_ERR_INPUT);
    snprintf(want, sizeof want, "%s: cannot open", path);
    assert_contains(err.message, want);
    assert_int_equal(vdbs_mesh_load_obj(test_tmp_path(""), NULL, &m, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "cannot read");
}

/* The distance from the centre to the nearest face plane of a UV sphere of radius r. A
 * stack's quad (or pole triangle) spans the slices +-h = pi / segments about its middle
 * meridian; by that symmetry its plane holds the chord across the meridian, so in the
 * meridian's plane it is the line through (sin t0 cos h, cos t0) and (sin t1 cos h, cos t1)
 * of the stack's boundaries t0, t1. */
static double uv_sphere_inradius(int segments, int stacks, double r)
{
    double h = pi / segments, nearest = INFINITY;
    for (int j = 0; j < stacks; ++j) {
        double t0 = pi * j / stacks, t1 = pi * (j + 1) / stacks;
        double ax = sin(t0) * cos(h), ay = cos(t0), bx = sin(t1) * cos(h), by = cos(t1);
        nearest = fmin(nearest, fabs(ax * by - ay * bx) / hypot(bx - ax, by - ay));
    }
    return r * nearest;
}

/* The tessellation is convex with its corners on the sphere: it lies in the ball of radius
 * r and holds the ball of its inradius, so its area and volume lie between those two
 * balls' (a convex body inside another has the smaller area). */
static void check_sphere(int segments)
{
    const double c[3] = {1.0, -2.0, 0.5}, r = 1.5;
    vdbs_error err = {{0}};
    vdbs_mesh m = {0};
    assert_int_equal(vdbs_mesh_sphere(c, r, segments, &m, &err), VDBS_OK);
    int stacks = segments / 2 < 2 ? 2 : segments / 2;
    assert_int_equal(m.triangle_count, 2 * segments * (stacks - 1));
    double inner = uv_sphere_inradius(segments, stacks, r);
    double area = vdbs_mesh_area(&m), vol = vdbs_mesh_volume(&m);
    double area_hi = 4.0 * pi * r * r, vol_hi = 4.0 / 3.0 * pi * r * r * r;
    double area_lo = 4.0 * pi * inner * inner, vol_lo = 4.0 / 3.0 * pi * inner * inner * inner;
    /* float corners: a relative 1e-6 of slack */
    if (!(area >= area_lo * (1 - 1e-6) && area <= area_hi * (1 + 1e-6)))
        fail_msg("segments %d: area %g not in [%g, %g]", segments, area, area_lo, area_hi);
    if (!(vol >= vol_lo * (1 - 1e-6) && vol <= vol_hi * (1 + 1e-6)))
        fail_msg("segments %d: volume %g not in [%g, %g]", segments, vol, vol_lo, vol_hi);
    /* the corners are on the sphere and the normals are the sphere's, outward */
    for (int t = 0; t < m.triangle_count; ++t)
        for (int k = 0; k < 3; ++k) {
            const float *p = m.positions + 9 * t + 3 * k, *n = m.normals + 9 * t + 3 * k;
            double d[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
            double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            assert_near(len, r, 1e-5, "corner on the sphere");
            for (int a = 0; a < 3; ++a)
                assert_near(n[a], d[a] / len, 1e-5, "sphere normal");
        }
    double lo[3], hi[3];
    vdbs_mesh_bounds(&m, lo, hi);
    assert_near(hi[1], c[1] + r, 1e-6, "north pole");
    assert_near(lo[1], c[1] - r, 1e-6, "south pole");
    vdbs_mesh_free(&m);
}

static void test_sphere(void **state)
{
    (void)state;
    check_sphere(3);
    check_sphere(8);
    check_sphere(48);
    check_sphere(256);
    /* and it converges: the inradius bound is within 0.03% at 256 segments */
    assert_true(uv_sphere_inradius(256, 128, 1.0) > 1.0 - 3e-4);
    vdbs_error err = {{0}};
    vdbs_mesh m = {0};
    const double c[3] = {0.0, 0.0, 0.0};
    assert_int_equal(vdbs_mesh_sphere(c, 1.0, 2, &m, &err), VDBS_ERR_INPUT);
    assert_int_equal(vdbs_mesh_sphere(c, 0.0, 16, &m, &err), VDBS_ERR_INPUT);
}

static void test_box_and_plane(void **state)
{
    (void)state;
    vdbs_error err = {{0}};
    vdbs_mesh m = {0};
    const double lo[3] = {-1.0, 0.0, 2.0}, hi[3] = {1.0, 0.5, 5.0};
    assert_int_equal(vdbs_mesh_box(lo, hi, &m, &err), VDBS_OK);
    assert_int_equal(m.triangle_count, 12);
    assert_near(vdbs_mesh_area(&m), 2.0 * (2.0 * 0.5 + 0.5 * 3.0 + 3.0 * 2.0), 1e-12, "box area");
    assert_near(vdbs_mesh_volume(&m), 2.0 * 0.5 * 3.0, 1e-12, "box volume");
    /* every corner's normal is its face's, pointing away from the centre */
    for (int t = 0; t < 12; ++t) {
        const float *p = m.positions + 9 * t, *n = m.normals + 9 * t;
        double out = 0.0;
        for (int a = 0; a < 3; ++a)
            out += n[a] * ((p[a] + p[3 + a] + p[6 + a]) / 3.0 - 0.5 * (lo[a] + hi[a]));
        assert_true(out > 0.0);
    }
    vdbs_mesh_free(&m);
    assert_int_equal(vdbs_mesh_box(hi, lo, &m, &err), VDBS_ERR_INPUT);

    /* a tilted plane: the quad lies on it, faces its normal, centred below the focus */
    const double point[3] = {0.0, 1.0, 0.0}, normal[3] = {0.0, 2.0, 2.0};
    const double focus[3] = {3.0, 5.0, 1.0};
    assert_int_equal(vdbs_mesh_plane(point, normal, focus, 10.0, &m, &err), VDBS_OK);
    assert_int_equal(m.triangle_count, 2);
    assert_near(vdbs_mesh_area(&m), 400.0, 400.0 * 1e-6, "plane area (float corners)");
    const double s = sqrt(0.5);
    for (int k = 0; k < 6; ++k) {
        const float *p = m.positions + 3 * k, *n = m.normals + 3 * k;
        assert_near((p[1] - 1.0) * s + p[2] * s, 0.0, 1e-5, "corner on the plane");
        assert_near(n[0], 0.0, 1e-6, "plane normal x");
        assert_near(n[1], s, 1e-6, "plane normal y");
        assert_near(n[2], s, 1e-6, "plane normal z");
    }
    /* the middle of the quad's bounds is the focus projected onto y + z = 1:
     * (3, 5, 1) - 2.5 (0, 1, 1) */
    double blo[3], bhi[3];
    vdbs_mesh_bounds(&m, blo, bhi);
    const double want[3] = {3.0, 2.5, -1.5};
    for (int a = 0; a < 3; ++a)
        assert_near(0.5 * (blo[a] + bhi[a]), want[a], 1e-5, "plane quad centre");
    vdbs_mesh_free(&m);
    const double zero[3] = {0.0, 0.0, 0.0};
    assert_int_equal(vdbs_mesh_plane(point, zero, focus, 10.0, &m, &err), VDBS_ERR_INPUT);
}

static void test_scene_occluders(void **state)
{
    (void)state;
    write_text("test_mesh_scene_cube.obj", cube_obj);
    const char *json =
        "{\"occluders\": ["
        " {\"type\": \"obj\", \"file\": \"test_mesh_scene_cube.obj\", \"translate\": [0, 3, 0],"
        "  \"scale\": 0.5},"
        " {\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 2},"
        " {\"type\": \"box\", \"min\": [0, 0, 0], \"max\": [1, 2, 3]},"
        " {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0, 1, 0]}]}";
    vdbs_scene *s = malloc(sizeof *s);
    assert_non_null(s);
    vdbs_scene_init(s);
    vdbs_error err = {{0}};
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", test_tmp_path(""));
    if (vdbs_scene_parse(json, dir, s, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(vdbs_occluders_check(s, &err), VDBS_OK);

    vdbs_mesh m = {0};
    double lo[3], hi[3];
    assert_int_equal(vdbs_occluder_mesh(s, 0, NULL, &m, &err), VDBS_OK);
    assert_int_equal(m.triangle_count, 12);
    vdbs_mesh_bounds(&m, lo, hi);
    assert_near(lo[1], 2.5, 1e-6, "placed cube bottom");
    assert_near(hi[1], 3.5, 1e-6, "placed cube top");
    vdbs_mesh_free(&m);

    vdbs_occluder_mesh_desc desc = {0};
    desc.sphere_segments = 16;
    assert_int_equal(vdbs_occluder_mesh(s, 1, &desc, &m, &err), VDBS_OK);
    assert_int_equal(m.triangle_count, 2 * 16 * 7);
    vdbs_mesh_free(&m);
    assert_int_equal(vdbs_occluder_mesh(s, 1, NULL, &m, &err), VDBS_OK);
    assert_int_equal(m.triangle_count, 2 * 48 * 23); /* the default 48 segments */
    vdbs_mesh_free(&m);

    assert_int_equal(vdbs_occluder_mesh(s, 2, NULL, &m, &err), VDBS_OK);
    assert_near(vdbs_mesh_volume(&m), 6.0, 1e-12, "box occluder volume");
    vdbs_mesh_free(&m);

    desc.plane_half_size = 50.0;
    desc.plane_focus[0] = 7.0;
    assert_int_equal(vdbs_occluder_mesh(s, 3, &desc, &m, &err), VDBS_OK);
    vdbs_mesh_bounds(&m, lo, hi);
    assert_near(lo[1], -1.0, 1e-6, "floor height");
    assert_near(hi[1], -1.0, 1e-6, "floor height");
    assert_near(hi[0] - lo[0], 100.0, 1e-4, "floor size");
    assert_near(0.5 * (hi[0] + lo[0]), 7.0, 1e-4, "floor centred below the focus");
    vdbs_mesh_free(&m);

    assert_int_equal(vdbs_occluder_mesh(s, 4, NULL, &m, &err), VDBS_ERR_INTERNAL);

    /* a broken OBJ among them: the check names the occluder, the file and the line */
    const char *bad = write_text("test_mesh_scene_bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    s->occluders[1] = s->occluders[0];
    assert_int_equal(vdbs_occluder_set_obj_file(s, &s->occluders[1], bad, &err), VDBS_OK);
    assert_int_equal(vdbs_occluders_check(s, &err), VDBS_ERR_INPUT);
    char want[4200];
    snprintf(want, sizeof want, "occluders[1].file: %s:3: f: corner '3': vertex index 3", bad);
    assert_contains(err.message, want);
    free(s);
}

/* samples/pillar.obj (samples/make_pillar.py): 52 triangles, closed pieces wound outward,
 * an octagonal shaft of radius 0.25 and height 1.7 between two 0.7 x 0.15 x 0.7 slabs. */
static void test_sample_pillar(void **state)
{
    (void)state;
    char path[4096];
    snprintf(path, sizeof path, "%s/pillar.obj", VDBS_TEST_SAMPLES_DIR);
    vdbs_error err = {{0}};
    vdbs_mesh m = {0};
    if (vdbs_mesh_load_obj(path, NULL, &m, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(m.triangle_count, 52);
    double lo[3], hi[3];
    vdbs_mesh_bounds(&m, lo, hi);
    assert_near(lo[1], -1.0, 1e-6, "pillar bottom");
    assert_near(hi[1], 1.0, 1e-6, "pillar top");
    assert_near(hi[0], 0.35, 1e-6, "pillar half width");
    double octagon = 2.0 * sqrt(2.0) * 0.25 * 0.25;
    double volume = octagon * 1.7 + 2.0 * 0.7 * 0.15 * 0.7;
    assert_near(vdbs_mesh_volume(&m), volume, 1e-5, "pillar volume");
    vdbs_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_obj_cube),      cmocka_unit_test(test_obj_negative_indices),
        cmocka_unit_test(test_obj_malformed), cmocka_unit_test(test_sphere),
        cmocka_unit_test(test_box_and_plane), cmocka_unit_test(test_scene_occluders),
        cmocka_unit_test(test_sample_pillar),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
