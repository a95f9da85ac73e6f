#include "occluders.h"

#include "display.h"

#include <epoxy/gl.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/gpu.h"
#include "vdbscatter/mesh.h"
#include "vdbscatter/march_session.h"

/* Positions and normals interleaved, 6 floats a vertex. */
#define VERTEX_FLOATS 6
#define PLANE_HALF_EXTENTS 8.0

/* The sun's map: the frame's coordinates, depth along w to [-1, 1] over [0, range]. */
static const char sun_vertex[] =
    "#version 450\n"
    "layout(location = 0) in vec3 position;\n"
    "uniform vec3 origin, u, v, w;\n"
    "uniform float half_width, range;\n"
    "out float depth;\n"
    "void main() {\n"
    "    vec3 d = position - origin;\n"
    "    depth = dot(d, w);\n"
    "    gl_Position = vec4(dot(d, u) / half_width, dot(d, v) / half_width,\n"
    "                       2.0 * depth / range - 1.0, 1.0);\n"
    "}\n";
static const char sun_fragment[] = "#version 450\n"
                                   "in float depth;\n"
                                   "out float result;\n"
                                   "void main() { result = depth; }\n";

/* A cube face of a point light: axis a, sign s; the offset's other two components over
 * its major one address the face (shaders/vs_shadow.h), a perspective depth orders it. */
static const char cube_vertex[] =
    "#version 450\n"
    "layout(location = 0) in vec3 position;\n"
    "uniform vec3 light;\n"
    "uniform int axis;\n"
    "uniform float sign_, near, far;\n"
    "out vec3 offset;\n"
    "void main() {\n"
    "    vec3 d = position - light;\n"
    "    offset = d;\n"
    "    float w = sign_ * d[axis];\n"
    "    float z = (w * (far + near) - 2.0 * far * near) / (far - near);\n"
    "    gl_Position = vec4(d[(axis + 1) % 3], d[(axis + 2) % 3], z, w);\n"
    "}\n";
static const char cube_fragment[] = "#version 450\n"
                                    "in vec3 offset;\n"
                                    "out float result;\n"
                                    "void main() { result = length(offset); }\n";

/* The camera: the kernels' pinhole (camera.h) with a perspective depth for the z-test. */
static const char surface_vertex[] =
    "#version 450\n"
    "layout(location = 0) in vec3 position;\n"
    "layout(location = 1) in vec3 normal;\n"
    "uniform vec3 camera, right_scaled, up_scaled, forward;\n"
    "uniform float near, far;\n"
    "out vec3 world_position;\n"
    "out vec3 world_normal;\n"
    "void main() {\n"
    "    vec3 q = position - camera;\n"
    "    float w = dot(q, forward);\n"
    "    float z = (w * (far + near) - 2.0 * far * near) / (far - near);\n"
    "    gl_Position = vec4(dot(q, right_scaled), dot(q, up_scaled), z, w);\n"
    "    world_position = position;\n"
    "    world_normal = normal;\n"
    "}\n";

void view_occluders_free(view_occluders *o)
{
    if (o->vertex_buffer)
        glDeleteBuffers(1, &o->vertex_buffer);
    if (o->vertex_array)
        glDeleteVertexArrays(1, &o->vertex_array);
    unsigned programs[3] = {o->sun_program, o->cube_program, o->surface_program};
    for (int i = 0; i < 3; ++i)
        if (programs[i])
            glDeleteProgram(programs[i]);
    if (o->framebuffer)
        glDeleteFramebuffers(1, &o->framebuffer);
    if (o->colour)
        glDeleteTextures(1, &o->colour);
    if (o->depth)
        glDeleteRenderbuffers(1, &o->depth);
    unsigned buffers[6] = {o->ssbo_lights, o->ssbo_shadows, o->ssbo_fog,
                           o->ssbo_dummy,  o->ssbo_medium,  o->ssbo_light_grids};
    for (int i = 0; i < 6; ++i)
        if (buffers[i])
            glDeleteBuffers(1, &buffers[i]);
    free(o->first);
    free(o->vertices);
    free(o->albedo);
    free(o->pixels);
    memset(o, 0, sizeof *o);
}

/* Every occluder's triangles, positions and normals interleaved into *data (the caller
 * frees it, also on failure), with each one's range and albedo in o and the bounds of
 * those that are not planes. */
static vdbs_status mesh_occluders(view_occluders *o, const vdbs_scene *scene, const double focus[3],
                                  double extent, float **data, size_t *floats, vdbs_error *err)
{
    for (int a = 0; a < 3; ++a) {
        o->finite_lo[a] = INFINITY;
        o->finite_hi[a] = -INFINITY;
    }
    vdbs_occluder_mesh_desc md = {0};
    memcpy(md.plane_focus, focus, sizeof md.plane_focus);
    /* Planes as quads some scene sizes wide, not "infinite": interpolated depths across a
     * triangle of 1000 units lose the precision the shadow test needs (acne bands). */
    md.plane_half_size = PLANE_HALF_EXTENTS * extent;
    for (int i = 0; i < scene->occluder_count; ++i) {
        vdbs_mesh mesh = {0};
        vdbs_status st = vdbs_occluder_mesh(scene, i, &md, &mesh, err);
        if (st != VDBS_OK)
            return st;
        size_t add = (size_t)mesh.triangle_count * 3 * VERTEX_FLOATS;
        float *grown = realloc(*data, sizeof *grown * (*floats + add));
        if (!grown) {
            vdbs_mesh_free(&mesh);
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for occluder meshes");
        }
        *data = grown;
        float *out = grown + *floats;
        int is_plane = scene->occluders[i].type == VDBS_OCCLUDER_PLANE;
        for (int v = 0; v < 3 * mesh.triangle_count; ++v)
            for (int a = 0; a < 3; ++a) {
                float x = mesh.positions[3 * v + a];
                out[(size_t)v * VERTEX_FLOATS + (size_t)a] = x;
                out[(size_t)v * VERTEX_FLOATS + 3 + (size_t)a] = mesh.normals[3 * v + a];
                if (!is_plane) {
                    o->finite_lo[a] = fmin(o->finite_lo[a], x);
                    o->finite_hi[a] = fmax(o->finite_hi[a], x);
                    o->finite = 1;
                }
            }
        o->first[i] = (int)(*floats / VERTEX_FLOATS);
        o->vertices[i] = 3 * mesh.triangle_count;
        for (int c = 0; c < 3; ++c)
            o->albedo[i][c] = (float)scene->occluders[i].albedo[c];
        *floats += add;
        vdbs_mesh_free(&mesh);
    }
    return VDBS_OK;
}

static void upload_vertices(view_occluders *o, const float *data, size_t floats)
{
    glGenVertexArrays(1, &o->vertex_array);
    glGenBuffers(1, &o->vertex_buffer);
    glBindVertexArray(o->vertex_array);
    glBindBuffer(GL_ARRAY_BUFFER, o->vertex_buffer);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(sizeof *data * floats), data, GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, VERTEX_FLOATS * sizeof(float), (void *)0);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, VERTEX_FLOATS * sizeof(float),
                          (void *)(3 * sizeof(float)));
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
}

/* The three programs, the render target's framebuffer and the buffers the surfaces are
 * lit through (view_occluders_set_lighting). */
static vdbs_status create_programs(view_occluders *o, vdbs_error *err)
{
    const vdbs_shader_source *surface = vdbs_shader_find("occluder_surface.frag");
    if (!surface)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "occluder_surface.frag not embedded");
    vdbs_status st = view_gl_program(sun_vertex, sun_fragment, &o->sun_program, err);
    if (st == VDBS_OK)
        st = view_gl_program(cube_vertex, cube_fragment, &o->cube_program, err);
    if (st == VDBS_OK)
        st = view_gl_program(surface_vertex, surface->text, &o->surface_program, err);
    if (st != VDBS_OK)
        return st;
    glGenFramebuffers(1, &o->framebuffer);
    GLuint b[6];
    glGenBuffers(6, b);
    o->ssbo_lights = b[0];
    o->ssbo_shadows = b[1];
    o->ssbo_fog = b[2];
    o->ssbo_dummy = b[3];
    o->ssbo_medium = b[4];
    o->ssbo_light_grids = b[5];
    const float zero[4] = {0, 0, 0, 0};
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, o->ssbo_dummy);
    glBufferData(GL_SHADER_STORAGE_BUFFER, sizeof zero, zero, GL_STATIC_DRAW);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, 0);
    return VDBS_OK;
}

vdbs_status view_occluders_init(view_occluders *o, const vdbs_scene *scene, const double focus[3],
                                double extent, vdbs_error *err)
{
    memset(o, 0, sizeof *o);
    if (scene->occluder_count == 0)
        return VDBS_OK;
    int n = scene->occluder_count;
    o->first = calloc((size_t)n, sizeof *o->first);
    o->vertices = calloc((size_t)n, sizeof *o->vertices);
    o->albedo = calloc((size_t)n, sizeof *o->albedo);
    if (!o->first || !o->vertices || !o->albedo) {
        view_occluders_free(o);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for occluders");
    }
    float *data = NULL;
    size_t floats = 0;
    vdbs_status st = mesh_occluders(o, scene, focus, extent, &data, &floats, err);
    if (st == VDBS_OK) {
        upload_vertices(o, data, floats);
        o->count = n;
    }
    free(data);
    if (st == VDBS_OK)
        st = create_programs(o, err);
    if (st != VDBS_OK)
        view_occluders_free(o);
    return st;
}

/* A float target of width x height: one R (maps) or RGBA (backdrop) colour texture and a
 * depth buffer, cleared to `clear`. */
static vdbs_status target_begin(view_occluders *o, int width, int height, int rgba,
                                const float clear[4], vdbs_error *err)
{
    if (o->colour)
        glDeleteTextures(1, &o->colour);
    if (o->depth)
        glDeleteRenderbuffers(1, &o->depth);
    glGenTextures(1, &o->colour);
    glBindTexture(GL_TEXTURE_2D, o->colour);
    glTexImage2D(GL_TEXTURE_2D, 0, rgba ? GL_RGBA32F : GL_R32F, width, height, 0,
                 rgba ? GL_RGBA : GL_RED, GL_FLOAT, NULL);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glBindTexture(GL_TEXTURE_2D, 0);
    glGenRenderbuffers(1, &o->depth);
    glBindRenderbuffer(GL_RENDERBUFFER, o->depth);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
    glBindRenderbuffer(GL_RENDERBUFFER, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, o->framebuffer);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, o->colour, 0);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, o->depth);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        return vdbs_error_set(err, VDBS_ERR_GPU, "occluders: float render target unsupported");
    }
    size_t need = (size_t)width * (size_t)height * (rgba ? 4u : 1u);
    float *grown = realloc(o->pixels, sizeof *grown * need);
    if (!grown)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for occluder maps");
    o->pixels = grown;
    o->target_width = width;
    o->target_height = height;
    glViewport(0, 0, width, height);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glClearBufferfv(GL_COLOR, 0, clear);
    glClearDepth(1.0);
    glClear(GL_DEPTH_BUFFER_BIT);
    return VDBS_OK;
}

static void draw_all(view_occluders *o, unsigned program, int with_albedo)
{
    glBindVertexArray(o->vertex_array);
    GLint albedo = glGetUniformLocation(program, "albedo");
    for (int i = 0; i < o->count; ++i) {
        if (with_albedo)
            glUniform3fv(albedo, 1, o->albedo[i]);
        glDrawArrays(GL_TRIANGLES, o->first[i], o->vertices[i]);
    }
    glBindVertexArray(0);
}

static void read_target(view_occluders *o, int rgba)
{
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, o->target_width, o->target_height, rgba ? GL_RGBA : GL_RED, GL_FLOAT,
                 o->pixels);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

static void uniform3(unsigned program, const char *name, const double v[3])
{
    glUniform3f(glGetUniformLocation(program, name), (float)v[0], (float)v[1], (float)v[2]);
}

vdbs_status view_occluders_shadow_maps(view_occluders *o, const vdbs_scene *scene,
                                       const double lo[3], const double hi[3], int res,
                                       vdbs_shadow_table *table, vdbs_error *err)
{
    int direct = 0;
    for (int i = 0; i < scene->light_count; ++i)
        direct += scene->lights[i].type != VDBS_LIGHT_ENV;
    vdbs_status st = vdbs_shadow_table_init(table, direct, err);
    if (st != VDBS_OK || o->count == 0)
        return st;
    double extent = 0.0;
    for (int a = 0; a < 3; ++a)
        extent = fmax(extent, hi[a] - lo[a]);
    /* Depth slack against self-shadowing: a few texels of the map's footprint. */
    const float clear[4] = {VDBS_NO_OCCLUDER, 0, 0, 0};
    int k = 0;
    for (int i = 0; i < scene->light_count && st == VDBS_OK; ++i) {
        const vdbs_light *light = &scene->lights[i];
        if (light->type == VDBS_LIGHT_ENV)
            continue;
        if (light->type == VDBS_LIGHT_SUN) {
            vdbs_shadow_sun_frame f;
            if ((st = vdbs_shadow_sun_frame_fit(light->direction, lo, hi, &f, err)) != VDBS_OK ||
                (st = target_begin(o, res, res, 0, clear, err)) != VDBS_OK)
                break;
            glUseProgram(o->sun_program);
            uniform3(o->sun_program, "origin", f.origin);
            uniform3(o->sun_program, "u", f.u);
            uniform3(o->sun_program, "v", f.v);
            uniform3(o->sun_program, "w", f.w);
            glUniform1f(glGetUniformLocation(o->sun_program, "half_width"), (float)f.half);
            glUniform1f(glGetUniformLocation(o->sun_program, "range"), (float)f.range);
            draw_all(o, o->sun_program, 0);
            read_target(o, 0);
            st = vdbs_shadow_table_set_sun(table, k, &f, res, o->pixels, 2.0 * f.half / res, err);
        } else {
            int face_res = res / 2 > 16 ? res / 2 : 16;
            float *faces = malloc(sizeof *faces * 6 * (size_t)face_res * (size_t)face_res);
            if (!faces) {
                st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a cube map");
                break;
            }
            for (int face = 0; face < 6 && st == VDBS_OK; ++face) {
                if ((st = target_begin(o, face_res, face_res, 0, clear, err)) != VDBS_OK)
                    break;
                glUseProgram(o->cube_program);
                uniform3(o->cube_program, "light", light->position);
                glUniform1i(glGetUniformLocation(o->cube_program, "axis"), face / 2);
                glUniform1f(glGetUniformLocation(o->cube_program, "sign_"),
                            face % 2 ? -1.0f : 1.0f);
                glUniform1f(glGetUniformLocation(o->cube_program, "near"), (float)(1e-4 * extent));
                glUniform1f(glGetUniformLocation(o->cube_program, "far"), (float)(1e3 * extent));
                draw_all(o, o->cube_program, 0);
                read_target(o, 0);
                memcpy(faces + (size_t)face * face_res * face_res, o->pixels,
                       sizeof *faces * (size_t)face_res * face_res);
            }
            if (st == VDBS_OK)
                st = vdbs_shadow_table_set_cube(table, k, light->position, face_res, faces,
                                                4.0 * extent / face_res, err);
            free(faces);
        }
        ++k;
    }
    glUseProgram(0);
    return st;
}

static void upload(unsigned buffer, const void *data, size_t bytes)
{
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, buffer);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)bytes, data, GL_DYNAMIC_DRAW);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, 0);
}

void view_occluders_set_lighting(view_occluders *o, const vdbs_march_tables *tables,
                                 const double world_to_index[3][4],
                                 const vdbs_shadow_table *shadows)
{
    if (o->count == 0)
        return;
    upload(o->ssbo_lights, tables->lights, sizeof *tables->lights * tables->light_floats);
    upload(o->ssbo_medium, tables->medium, sizeof *tables->medium * tables->medium_floats);
    o->with_light_grids = tables->light_grids != NULL;
    if (tables->light_grids)
        upload(o->ssbo_light_grids, tables->light_grids,
               sizeof *tables->light_grids * tables->light_grid_words);
    upload(o->ssbo_shadows, shadows->data, sizeof *shadows->data * shadows->floats);
    memcpy(o->world_to_index, world_to_index, sizeof o->world_to_index);
}

void view_occluders_set_fog(view_occluders *o, const vdbs_march_fog *fog)
{
    o->fog = fog && fog->fog ? fog : NULL;
    if (o->count > 0 && o->fog)
        upload(o->ssbo_fog, fog->fog->table, sizeof *fog->fog->table * fog->fog->table_floats);
}

vdbs_status view_occluders_backdrop(view_occluders *o, const vdbs_camera_frame *frame,
                                    float *backdrop, vdbs_error *err)
{
    const vdbs_march_fog *fog = o->fog;
    const float clear[4] = {VDBS_NO_SURFACE, 0, 0, 0};
    vdbs_status st = target_begin(o, frame->width, frame->height, 1, clear, err);
    if (st != VDBS_OK)
        return st;
    unsigned p = o->surface_program;
    glUseProgram(p);
    uniform3(p, "camera", frame->origin);
    double right[3], up[3];
    for (int a = 0; a < 3; ++a) {
        right[a] = frame->right[a] / frame->tan_half_x;
        up[a] = frame->up[a] / frame->tan_half_y;
    }
    uniform3(p, "right_scaled", right);
    uniform3(p, "up_scaled", up);
    uniform3(p, "forward", frame->forward);
    glUniform1f(glGetUniformLocation(p, "near"), 1e-3f);
    glUniform1f(glGetUniformLocation(p, "far"), 1e5f);
    glUniform1i(glGetUniformLocation(p, "with_fog"), fog ? 1 : 0);
    glUniform1i(glGetUniformLocation(p, "with_light_grids"), o->with_light_grids);
    float rows[12];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            rows[4 * r + c] = (float)o->world_to_index[r][c];
    glUniform4fv(glGetUniformLocation(p, "to_index"), 3, rows);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, o->ssbo_dummy);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, o->ssbo_medium);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, o->ssbo_lights);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, o->ssbo_shadows);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5,
                     o->with_light_grids ? o->ssbo_light_grids : o->ssbo_dummy);
    if (fog) {
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, o->ssbo_fog);
        uniform3(p, "fog_lo", fog->box_lo);
        uniform3(p, "fog_hi", fog->box_hi);
        uniform3(p, "fog_albedo", fog->albedo);
    } else {
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, o->ssbo_dummy);
    }
    draw_all(o, p, 1);
    glUseProgram(0);
    read_target(o, 1);
    /* glReadPixels' row 0 is the bottom; the kernels' is the top. */
    for (int y = 0; y < frame->height; ++y)
        memcpy(backdrop + 4 * (size_t)y * frame->width,
               o->pixels + 4 * (size_t)(frame->height - 1 - y) * frame->width,
               sizeof *backdrop * 4 * (size_t)frame->width);
    return VDBS_OK;
}
