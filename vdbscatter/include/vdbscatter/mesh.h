/* Triangle meshes of the scene's solid occluders: Wavefront OBJ files read by a strict
 * parser, and tessellated primitives (sphere, box, plane), all in one shape so that the
 * viewer draws every occluder the same way. */
#ifndef VDBSCATTER_MESH_H
#define VDBSCATTER_MESH_H

#include "vdbscatter/scene.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Unindexed triangles in world space, ready for one vertex buffer each: triangle t has
 * its corners at positions[9t .. 9t+8], counter-clockwise seen from the side its normal
 * faces, and a unit normal per corner at normals[9t .. 9t+8]. Zero-initialise; free with
 * vdbs_mesh_free. */
typedef struct vdbs_mesh {
    float *positions;
    float *normals;
    int triangle_count;
} vdbs_mesh;

/* Frees the arrays and zeroes the mesh (a zeroed mesh may be freed too). */
void vdbs_mesh_free(vdbs_mesh *mesh);

/* Placement of an OBJ file's vertices: p_world = translate + R (scale * p_file), with
 * R = Rz Ry Rx of rotate_deg (about X first). Zero-initialised = identity: a scale
 * component of 0 stands for 1. */
typedef struct vdbs_mesh_transform {
    double translate[3];
    double scale[3];
    double rotate_deg[3];
} vdbs_mesh_transform;

/* Reads a Wavefront OBJ file (transform may be NULL: identity). Accepted: v (x y z, with an
 * optional w or r g b after), vt, vn, f with v, v/vt, v//vn or v/vt/vn corners (1-based or
 * negative relative indices, to elements defined above the face), polygons of 3 or more
 * corners fan-triangulated, and o, g, s, usemtl, mtllib, comments and blank lines, which
 * are ignored. A corner without vn gets its triangle's face normal; triangles of zero area
 * are dropped. Anything else is VDBS_ERR_INPUT "PATH:LINE: what is wrong", as are a file
 * that cannot be read ("PATH: cannot open: ...") and one without a triangle. */
vdbs_status vdbs_mesh_load_obj(const char *path, const vdbs_mesh_transform *transform,
                               vdbs_mesh *out, vdbs_error *err);

/* A UV sphere of `segments` slices around its Y axis and segments / 2 stacks (at least 2),
 * corners on the sphere, normals the sphere's. segments in [3, 4096]. */
vdbs_status vdbs_mesh_sphere(const double center[3], double radius, int segments, vdbs_mesh *out,
                             vdbs_error *err);

/* The 12 triangles of an axis-aligned box, normals outward. */
vdbs_status vdbs_mesh_box(const double min[3], const double max[3], vdbs_mesh *out,
                          vdbs_error *err);

/* A square of 2 triangles on the plane through `point` with normal `normal` (its front),
 * of side 2 * half_size, centred where `focus` projects onto the plane (an infinite plane
 * drawn as a quad much larger than the scene). */
vdbs_status vdbs_mesh_plane(const double point[3], const double normal[3], const double focus[3],
                            double half_size, vdbs_mesh *out, vdbs_error *err);

/* Options of vdbs_occluder_mesh; zero-initialised = the defaults. */
typedef struct vdbs_occluder_mesh_desc {
    int sphere_segments;    /* 0: 48 */
    double plane_focus[3];  /* the plane quad's centre projects from here (the volume's centre) */
    double plane_half_size; /* 0: 1000 world units */
} vdbs_occluder_mesh_desc;

/* The triangles of scene->occluders[index] (desc may be NULL). An OBJ file's errors are
 * those of vdbs_mesh_load_obj. */
vdbs_status vdbs_occluder_mesh(const vdbs_scene *scene, int index,
                               const vdbs_occluder_mesh_desc *desc, vdbs_mesh *out,
                               vdbs_error *err);

/* Reads every OBJ occluder of the scene once and drops it: for the commands that ignore
 * occluders but must still refuse a scene naming a missing or malformed file. Errors are
 * VDBS_ERR_INPUT "occluders[I].file: " followed by vdbs_mesh_load_obj's message. */
vdbs_status vdbs_occluders_check(const vdbs_scene *scene, vdbs_error *err);

/* Surface area, enclosed volume (divergence theorem: positive for a closed mesh whose
 * triangles face outward) and bounds of a mesh; bounds of an empty mesh are +inf / -inf. */
double vdbs_mesh_area(const vdbs_mesh *mesh);
double vdbs_mesh_volume(const vdbs_mesh *mesh);
void vdbs_mesh_bounds(const vdbs_mesh *mesh, double min[3], double max[3]);

#ifdef __cplusplus
}
#endif

#endif
