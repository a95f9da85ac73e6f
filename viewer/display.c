#include "display.h"

#include <epoxy/gl.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

/* One triangle that covers the screen, no vertex buffer. */
static const char vertex_source[] =
    "#version 430 core\n"
    "out vec2 uv;\n"
    "void main() {\n"
    "    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));\n"
    "    uv = vec2(p.x, 1.0 - p.y); /* image row 0 is the top */\n"
    "    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);\n"
    "}\n";

/* Exposure, then the sRGB curve (the default framebuffer is not an sRGB one). */
static const char fragment_source[] =
    "#version 430 core\n"
    "in vec2 uv;\n"
    "out vec4 colour;\n"
    "uniform sampler2D picture;\n"
    "uniform float scale;\n"
    "float srgb(float x) {\n"
    "    x = clamp(x, 0.0, 1.0);\n"
    "    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;\n"
    "}\n"
    "void main() {\n"
    "    vec3 c = texture(picture, uv).rgb * scale;\n"
    "    colour = vec4(srgb(c.r), srgb(c.g), srgb(c.b), 1.0);\n"
    "}\n";

static vdbs_status compile(GLenum kind, const char *text, GLuint *shader, vdbs_error *err)
{
    *shader = glCreateShader(kind);
    glShaderSource(*shader, 1, &text, NULL);
    glCompileShader(*shader);
    GLint ok = 0;
    glGetShaderiv(*shader, GL_COMPILE_STATUS, &ok);
    if (ok)
        return VDBS_OK;
    /* The driver's errors only (warnings are many in PNanoVDB.h), on one line. */
    static char log[65536];
    log[0] = '\0';
    glGetShaderInfoLog(*shader, sizeof log, NULL, log);
    char errors[VDBS_ERROR_MAX] = "";
    size_t used = 0;
    for (char *line = strtok(log, "\n"); line; line = strtok(NULL, "\n"))
        if (strstr(line, "error") && used + 2 < sizeof errors)
            used += (size_t)snprintf(errors + used, sizeof errors - used, "%s%s", used ? "; " : "",
                                     line);
    return vdbs_error_set(err, VDBS_ERR_GPU, "viewer shader: %s", errors[0] ? errors : log);
}

vdbs_status view_gl_program(const char *vertex, const char *fragment, unsigned *program,
                            vdbs_error *err)
{
    GLuint vs = 0, fs = 0;
    *program = 0;
    vdbs_status st = compile(GL_VERTEX_SHADER, vertex, &vs, err);
    if (st == VDBS_OK)
        st = compile(GL_FRAGMENT_SHADER, fragment, &fs, err);
    if (st == VDBS_OK) {
        *program = glCreateProgram();
        glAttachShader(*program, vs);
        glAttachShader(*program, fs);
        glLinkProgram(*program);
        GLint ok = 0;
        glGetProgramiv(*program, GL_LINK_STATUS, &ok);
        if (!ok)
            st = vdbs_error_set(err, VDBS_ERR_GPU, "viewer shaders: link failed");
    }
    glDeleteShader(vs);
    glDeleteShader(fs);
    return st;
}

vdbs_status view_display_init(view_display *d, vdbs_error *err)
{
    memset(d, 0, sizeof *d);
    vdbs_status st = view_gl_program(vertex_source, fragment_source, &d->program, err);
    glGenVertexArrays(1, &d->vertex_array);
    glGenTextures(1, &d->texture);
    if (st != VDBS_OK)
        view_display_free(d);
    return st;
}

void view_display_free(view_display *d)
{
    if (d->program)
        glDeleteProgram(d->program);
    if (d->texture)
        glDeleteTextures(1, &d->texture);
    if (d->vertex_array)
        glDeleteVertexArrays(1, &d->vertex_array);
    memset(d, 0, sizeof *d);
}

void view_display_draw(view_display *d, const vdbs_image *image, double exposure_ev,
                       int framebuffer_width, int framebuffer_height)
{
    glBindTexture(GL_TEXTURE_2D, d->texture);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    if (d->width != image->width || d->height != image->height) {
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, image->width, image->height, 0, GL_RGB, GL_FLOAT,
                     image->rgb);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        d->width = image->width;
        d->height = image->height;
    } else {
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image->width, image->height, GL_RGB, GL_FLOAT,
                        image->rgb);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, framebuffer_width, framebuffer_height);
    glDisable(GL_DEPTH_TEST);
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    glUseProgram(d->program);
    glUniform1i(glGetUniformLocation(d->program, "picture"), 0);
    glUniform1f(glGetUniformLocation(d->program, "scale"), (float)pow(2.0, exposure_ev));
    glActiveTexture(GL_TEXTURE0);
    glBindVertexArray(d->vertex_array);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glUseProgram(0);
}
