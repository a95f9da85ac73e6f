/* Headless OpenGL compute through EGL; GL and EGL entry points come from libepoxy. */
#include "vdbscatter/gpu.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_EGL_DEVICES 32

struct vdbs_gpu {
    EGLDisplay display; /* EGL_NO_DISPLAY for an adopted context */
    EGLContext context;
    vdbs_gpu_info info;
};

/* EGL shares one display per platform and native handle within a process and
 * eglTerminate ends it for every user, so displays are reference-counted here and
 * terminated when the last vdbs_gpu using one goes away. */
static struct {
    EGLDisplay display;
    int refs;
} g_displays[8];

static void display_acquire(EGLDisplay dpy)
{
    int free_slot = -1;
    for (int i = 0; i < (int)(sizeof g_displays / sizeof g_displays[0]); i++) {
        if (g_displays[i].refs > 0 && g_displays[i].display == dpy) {
            g_displays[i].refs++;
            return;
        }
        if (g_displays[i].refs == 0 && free_slot < 0)
            free_slot = i;
    }
    /* With the table full the display is simply never terminated. */
    if (free_slot >= 0) {
        g_displays[free_slot].display = dpy;
        g_displays[free_slot].refs = 1;
    }
}

static void display_release(EGLDisplay dpy)
{
    int any_left = 0;
    for (int i = 0; i < (int)(sizeof g_displays / sizeof g_displays[0]); i++) {
        if (g_displays[i].refs > 0 && g_displays[i].display == dpy) {
            if (--g_displays[i].refs == 0)
                eglTerminate(dpy);
        }
        any_left |= g_displays[i].refs > 0;
    }
    /* Frees EGL's per-thread state once no display of ours is in use. */
    if (!any_left)
        eglReleaseThread();
}

static const char *egl_error_name(EGLint code)
{
    switch (code) {
    case EGL_SUCCESS:
        return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
        return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
        return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
        return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
        return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
        return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
        return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE:
        return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY:
        return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
        return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP:
        return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW:
        return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER:
        return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE:
        return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST:
        return "EGL_CONTEXT_LOST";
    default:
        return "unknown EGL error";
    }
}

/* Whether a space-separated extension list holds `name` as a whole word. */
static int has_extension(const char *list, const char *name)
{
    if (!list)
        return 0;
    size_t len = strlen(name);
    for (const char *p = list; (p = strstr(p, name)) != NULL; p += len) {
        int starts = p == list || p[-1] == ' ';
        int ends = p[len] == ' ' || p[len] == '\0';
        if (starts && ends)
            return 1;
    }
    return 0;
}

static int has_client_extension(const char *name)
{
    /* Without EGL_EXT_client_extensions this returns NULL (EGL_BAD_DISPLAY). */
    return has_extension(eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS), name);
}

static int device_is_software(EGLDeviceEXT device)
{
    return has_extension(eglQueryDeviceStringEXT(device, EGL_EXTENSIONS),
                         "EGL_MESA_device_software");
}

/* Lists EGL devices; returns the count (0 when enumeration is unsupported). */
static int query_devices(EGLDeviceEXT *devices, int max)
{
    if (!has_client_extension("EGL_EXT_device_enumeration") &&
        !has_client_extension("EGL_EXT_device_base"))
        return 0;
    EGLint count = 0;
    if (!eglQueryDevicesEXT(max, devices, &count) || count < 0)
        return 0;
    return count;
}

int vdbs_gpu_hardware_available(void)
{
    EGLDeviceEXT devices[MAX_EGL_DEVICES];
    int count = query_devices(devices, MAX_EGL_DEVICES);
    for (int i = 0; i < count; i++)
        if (!device_is_software(devices[i]))
            return 1;
    return 0;
}

/* Appends formatted text to a fixed buffer, truncating silently. */
static void appendf(char *buf, size_t size, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static void appendf(char *buf, size_t size, const char *fmt, ...)
{
    size_t used = strlen(buf);
    if (used + 1 >= size)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf + used, size - used, fmt, ap);
    va_end(ap);
}

static void copy_gl_string(char *dst, size_t size, GLenum name)
{
    const GLubyte *s = glGetString(name);
    snprintf(dst, size, "%s", s ? (const char *)s : "");
}

/* Initialises `dpy`, makes a 4.3+ core context current and fills gpu on success;
 * otherwise writes what went wrong to `why` and leaves the display as it was. */
/* Buffers use direct state access: core in 4.5, an extension before. */
static int has_direct_state_access(void)
{
    return epoxy_gl_version() >= 45 || epoxy_has_gl_extension("GL_ARB_direct_state_access");
}

/* What the current context is and can do. */
static void read_info(vdbs_gpu_info *info)
{
    copy_gl_string(info->vendor, sizeof info->vendor, GL_VENDOR);
    copy_gl_string(info->renderer, sizeof info->renderer, GL_RENDERER);
    copy_gl_string(info->version, sizeof info->version, GL_VERSION);
    copy_gl_string(info->glsl_version, sizeof info->glsl_version, GL_SHADING_LANGUAGE_VERSION);
    static const char *const software_names[] = {"llvmpipe", "softpipe", "swrast", "SwiftShader"};
    for (size_t i = 0; i < sizeof software_names / sizeof software_names[0]; i++)
        if (strstr(info->renderer, software_names[i]))
            info->is_software = 1;
    GLint64 ssbo = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &ssbo);
    info->max_ssbo_bytes = ssbo;
    GLint value = 0;
    glGetIntegerv(GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS, &value);
    info->max_work_group_invocations = value;
    for (GLuint i = 0; i < 3; i++) {
        value = 0;
        glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, i, &value);
        info->max_work_group_count[i] = value;
    }
}

static int try_display(vdbs_gpu *gpu, EGLDisplay dpy, char *why, size_t why_size)
{
    if (dpy == EGL_NO_DISPLAY) {
        snprintf(why, why_size, "no display (%s)", egl_error_name(eglGetError()));
        return 0;
    }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy, &major, &minor)) {
        snprintf(why, why_size, "eglInitialize failed (%s)", egl_error_name(eglGetError()));
        return 0;
    }
    display_acquire(dpy);

    EGLContext ctx = EGL_NO_CONTEXT;
    const char *exts = eglQueryString(dpy, EGL_EXTENSIONS);
    if (!eglBindAPI(EGL_OPENGL_API)) {
        snprintf(why, why_size, "eglBindAPI(EGL_OPENGL_API) failed (%s)",
                 egl_error_name(eglGetError()));
        goto fail;
    }
    if (!has_extension(exts, "EGL_KHR_surfaceless_context")) {
        snprintf(why, why_size, "EGL %d.%d without EGL_KHR_surfaceless_context", major, minor);
        goto fail;
    }
    EGLConfig config = EGL_NO_CONFIG_KHR;
    if (!has_extension(exts, "EGL_KHR_no_config_context") &&
        !has_extension(exts, "EGL_MESA_configless_context")) {
        const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0,
                                         EGL_NONE};
        EGLint n = 0;
        if (!eglChooseConfig(dpy, config_attribs, &config, 1, &n) || n < 1) {
            snprintf(why, why_size, "no EGL config for desktop OpenGL (%s)",
                     egl_error_name(eglGetError()));
            goto fail;
        }
    }
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                      4,
                                      EGL_CONTEXT_MINOR_VERSION,
                                      3,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                      EGL_NONE};
    ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, context_attribs);
    if (ctx == EGL_NO_CONTEXT) {
        snprintf(why, why_size, "no OpenGL 4.3 core context (%s)", egl_error_name(eglGetError()));
        goto fail;
    }
    if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
        snprintf(why, why_size, "eglMakeCurrent without surface failed (%s)",
                 egl_error_name(eglGetError()));
        goto fail;
    }
    if (!has_direct_state_access()) {
        const GLubyte *version = glGetString(GL_VERSION);
        snprintf(why, why_size, "OpenGL %s has no GL_ARB_direct_state_access",
                 version ? (const char *)version : "(unknown)");
        eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        goto fail;
    }

    gpu->display = dpy;
    gpu->context = ctx;
    read_info(&gpu->info);
    return 1;

fail:
    if (ctx != EGL_NO_CONTEXT)
        eglDestroyContext(dpy, ctx);
    display_release(dpy);
    return 0;
}

static int try_device_platform(vdbs_gpu *gpu, char *why, size_t why_size)
{
    if (!has_client_extension("EGL_EXT_platform_device")) {
        snprintf(why, why_size, "EGL_EXT_platform_device not supported");
        return 0;
    }
    EGLDeviceEXT devices[MAX_EGL_DEVICES];
    int count = query_devices(devices, MAX_EGL_DEVICES);
    if (count == 0) {
        snprintf(why, why_size, "no EGL devices");
        return 0;
    }
    why[0] = '\0';
    /* Hardware devices first, then software ones. */
    for (int pass = 0; pass < 2; pass++) {
        for (int i = 0; i < count; i++) {
            int software = device_is_software(devices[i]);
            if (software != pass)
                continue;
            EGLDisplay dpy = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], NULL);
            char device_why[256];
            if (try_display(gpu, dpy, device_why, sizeof device_why)) {
                gpu->info.is_software |= software;
                return 1;
            }
            appendf(why, why_size, "%sdevice %d (%s): %s", why[0] ? ", " : "", i,
                    software ? "software" : "hardware", device_why);
        }
    }
    return 0;
}

vdbs_status vdbs_gpu_create(vdbs_gpu **out, vdbs_error *err)
{
    *out = NULL;
    vdbs_gpu *gpu = calloc(1, sizeof *gpu);
    if (!gpu)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory creating the GPU context");

    char device_why[400] = "", surfaceless_why[256] = "", default_why[256] = "";
    if (try_device_platform(gpu, device_why, sizeof device_why)) {
        snprintf(gpu->info.platform, sizeof gpu->info.platform, "device");
    } else if (!has_client_extension("EGL_MESA_platform_surfaceless")) {
        snprintf(surfaceless_why, sizeof surfaceless_why,
                 "EGL_MESA_platform_surfaceless not supported");
    } else if (try_display(gpu,
                           eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA,
                                                    EGL_DEFAULT_DISPLAY, NULL),
                           surfaceless_why, sizeof surfaceless_why)) {
        snprintf(gpu->info.platform, sizeof gpu->info.platform, "surfaceless");
    }
    if (!gpu->info.platform[0]) {
        if (try_display(gpu, eglGetDisplay(EGL_DEFAULT_DISPLAY), default_why, sizeof default_why)) {
            snprintf(gpu->info.platform, sizeof gpu->info.platform, "default");
        } else {
            free(gpu);
            return vdbs_error_set(err, VDBS_ERR_GPU,
                                  "no OpenGL 4.3 core context through EGL: device platform: "
                                  "%s; surfaceless platform: %s; default display: %s",
                                  device_why, surfaceless_why, default_why);
        }
    }
    *out = gpu;
    return VDBS_OK;
}

vdbs_status vdbs_gpu_adopt_current(vdbs_gpu **out, vdbs_error *err)
{
    *out = NULL;
    if (epoxy_gl_version() < 43 || !has_direct_state_access())
        return vdbs_error_set(err, VDBS_ERR_GPU,
                              "the current OpenGL context (version %d.%d) lacks compute shaders "
                              "or direct state access (4.3 and 4.5 needed)",
                              epoxy_gl_version() / 10, epoxy_gl_version() % 10);
    vdbs_gpu *gpu = calloc(1, sizeof *gpu);
    if (!gpu)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory adopting the GL context");
    gpu->display = EGL_NO_DISPLAY;
    gpu->context = EGL_NO_CONTEXT;
    read_info(&gpu->info);
    snprintf(gpu->info.platform, sizeof gpu->info.platform, "window");
    *out = gpu;
    return VDBS_OK;
}

void vdbs_gpu_destroy(vdbs_gpu *gpu)
{
    if (!gpu)
        return;
    if (gpu->display == EGL_NO_DISPLAY) { /* adopted: the window owns the context */
        free(gpu);
        return;
    }
    eglMakeCurrent(gpu->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(gpu->display, gpu->context);
    display_release(gpu->display);
    free(gpu);
}

const vdbs_gpu_info *vdbs_gpu_get_info(const vdbs_gpu *gpu)
{
    return &gpu->info;
}

/* Drops errors left by earlier calls so that a check after our calls sees only ours. */
static void clear_gl_errors(void)
{
    for (int i = 0; i < 16 && glGetError() != GL_NO_ERROR; i++)
        ;
}

static const char *gl_error_name(GLenum code)
{
    switch (code) {
    case GL_INVALID_ENUM:
        return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE:
        return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION:
        return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
        return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY:
        return "GL_OUT_OF_MEMORY";
    case GL_STACK_OVERFLOW:
        return "GL_STACK_OVERFLOW";
    case GL_STACK_UNDERFLOW:
        return "GL_STACK_UNDERFLOW";
    default:
        return "unknown GL error";
    }
}

/* ---- programs ---- */

/* Mesa 22 drops the source-string number of `#line L F` from most compiler messages
 * (it says "0:L(C)" where F was meant). So the compiler sees each directive as
 * `#line V` with V = (F + 1) * LINE_STRIDE + L, and messages are decoded from V alone.
 * The directives are still needed: Mesa's preprocessor loses a line for every
 * function-like macro call that spans lines, and each directive resynchronises. */
#define LINE_STRIDE 1000000
#define LINE_MAX_FILES 2000 /* keeps V below 2^31 */

static int encode_line(int file, long line)
{
    return (file + 1) * LINE_STRIDE + (int)line;
}

static void decode_line(int reported, int *file, int *line)
{
    if (reported >= LINE_STRIDE) {
        *file = reported / LINE_STRIDE - 1;
        *line = reported % LINE_STRIDE;
    } else {
        /* Before the first directive: physical lines of file 0. */
        *file = 0;
        *line = reported;
    }
}

/* Reads a decimal number made of digits only, not crossing the end of the line. */
static int read_number(const char **p, long *value)
{
    while (**p == ' ' || **p == '\t')
        (*p)++;
    if (**p < '0' || **p > '9')
        return 0;
    long v = 0;
    while (**p >= '0' && **p <= '9') {
        if (v < LINE_STRIDE)
            v = v * 10 + (**p - '0');
        (*p)++;
    }
    *value = v;
    return 1;
}

/* Whether `line` is a `#line L [F]` directive; fills L and F (F = -1 when absent). */
static int parse_line_directive(const char *line, long *number, long *file)
{
    const char *p = line;
    while (*p == ' ' || *p == '\t')
        p++;
    if (*p++ != '#')
        return 0;
    while (*p == ' ' || *p == '\t')
        p++;
    if (strncmp(p, "line", 4) != 0 || (p[4] != ' ' && p[4] != '\t'))
        return 0;
    p += 4;
    if (!read_number(&p, number))
        return 0;
    if (!read_number(&p, file))
        *file = -1;
    return 1;
}

/* Where the #version line ends (just past its newline) and its 1-based line number;
 * 0 and 0 when there is none. Only comments and blank lines may precede it in GLSL. */
static size_t find_version_end(const char *text, int *version_line)
{
    int line = 1;
    const char *p = text;
    while (*p) {
        const char *q = p;
        while (*q == ' ' || *q == '\t')
            q++;
        const char *eol = strchr(p, '\n');
        size_t end = eol ? (size_t)(eol - text) + 1 : strlen(text);
        if (*q == '#') {
            q++;
            while (*q == ' ' || *q == '\t')
                q++;
            if (strncmp(q, "version", 7) == 0) {
                *version_line = line;
                return end;
            }
        }
        if (!eol)
            break;
        p = eol + 1;
        line++;
    }
    *version_line = 0;
    return 0;
}

/* Builds what the compiler sees: the text up to #version, the defines (as file
 * number file_count), the rest, with every #line directive encoded. */
static char *assemble_source(const vdbs_shader_source *source, const char *defines)
{
    int version_line = 0;
    const char *text = source->text;
    size_t head_len = find_version_end(text, &version_line);
    if (!defines)
        defines = "";
    size_t def_len = strlen(defines);
    size_t rest_len = strlen(text + head_len);
    size_t directives = 0;
    for (const char *p = text; (p = strstr(p, "line")) != NULL; p += 4)
        directives++;
    /* Encoded directives are at most "#line 2147483647\n". */
    size_t cap = head_len + def_len + rest_len + (directives + 2) * 24 + 4;
    char *out = malloc(cap);
    if (!out)
        return NULL;
    char *o = out;
    memcpy(o, text, head_len);
    o += head_len;
    if (head_len > 0 && text[head_len - 1] != '\n')
        *o++ = '\n';
    int encode = source->file_count >= 0 && source->file_count < LINE_MAX_FILES;
    if (def_len > 0) {
        if (encode)
            o += sprintf(o, "#line %d\n", encode_line(source->file_count, 1));
        memcpy(o, defines, def_len);
        o += def_len;
        if (defines[def_len - 1] != '\n')
            *o++ = '\n';
        o += sprintf(o, "#line %d\n", encode ? encode_line(0, version_line + 1) : version_line + 1);
    }

    int current_file = 0;
    for (const char *p = text + head_len; *p;) {
        const char *eol = strchr(p, '\n');
        size_t len = eol ? (size_t)(eol - p) + 1 : strlen(p);
        long number, file;
        if (encode && parse_line_directive(p, &number, &file) &&
            (file < 0 || file < LINE_MAX_FILES) && number < LINE_STRIDE) {
            if (file >= 0)
                current_file = (int)file;
            o += sprintf(o, "#line %d\n", encode_line(current_file, number));
        } else {
            memcpy(o, p, len);
            o += len;
        }
        p += len;
    }
    *o = '\0';
    return out;
}

/* Parses a compiler message's location: Mesa "S:L(C): ", NVIDIA "S(L) : " and the
 * "ERROR: S:L: " style of other drivers. Returns the offset of the text after it. */
static int parse_location(const char *line, int *reported)
{
    unsigned s, l, c;
    int n = 0;
    if (sscanf(line, "%u:%u(%u): %n", &s, &l, &c, &n) == 3 && n > 0) {
        *reported = (int)l;
        return n;
    }
    n = 0;
    if (sscanf(line, "%u(%u) : %n", &s, &l, &n) == 2 && n > 0) {
        *reported = (int)l;
        return n;
    }
    n = 0;
    if ((sscanf(line, "ERROR: %u:%u: %n", &s, &l, &n) == 2 ||
         sscanf(line, "WARNING: %u:%u: %n", &s, &l, &n) == 2) &&
        n > 0) {
        *reported = (int)l;
        return n;
    }
    return 0;
}

/* Appends the compiler's log to msg as "file:line: text" lines: only the errors when
 * there are any, as the 26-odd warnings from PNanoVDB.h would crowd them out. */
static void append_log(char *msg, size_t size, const char *log, const vdbs_shader_source *source)
{
    int errors = 0;
    for (int pass = 0; pass < 2 && !(pass == 1 && errors > 0); pass++) {
        int want_errors = pass == 0;
        const char *p = log;
        while (*p) {
            const char *eol = strchr(p, '\n');
            size_t len = eol ? (size_t)(eol - p) : strlen(p);
            char line[1024];
            snprintf(line, sizeof line, "%.*s", (int)len, p);
            p += len + (eol ? 1 : 0);
            if (len == 0)
                continue;
            int is_error = strstr(line, "error") != NULL || strstr(line, "ERROR") != NULL;
            if (is_error != want_errors)
                continue;
            errors += is_error;
            int reported = 0;
            int skip = parse_location(line, &reported);
            if (skip == 0) {
                appendf(msg, size, "\n%s", line);
                continue;
            }
            int file, line_no;
            decode_line(reported, &file, &line_no);
            const char *name = "?";
            if (file == source->file_count)
                name = "<defines>";
            else if (file >= 0 && file < source->file_count && source->files)
                name = source->files[file];
            appendf(msg, size, "\n%s:%d: %s", name, line_no, line + skip);
        }
    }
}

static char *get_log(GLuint object, int is_program)
{
    GLint len = 0;
    if (is_program)
        glGetProgramiv(object, GL_INFO_LOG_LENGTH, &len);
    else
        glGetShaderiv(object, GL_INFO_LOG_LENGTH, &len);
    char *log = malloc((size_t)(len > 0 ? len : 0) + 1);
    if (!log)
        return NULL;
    log[0] = '\0';
    if (len > 0) {
        if (is_program)
            glGetProgramInfoLog(object, len, NULL, log);
        else
            glGetShaderInfoLog(object, len, NULL, log);
        log[len] = '\0';
    }
    return log;
}

static vdbs_status build_failed(vdbs_error *err, const char *what, const char *name, char *log,
                                const vdbs_shader_source *source)
{
    vdbs_error_set(err, VDBS_ERR_GPU, "%s shader %s failed:", what, name);
    if (err)
        append_log(err->message, sizeof err->message, log ? log : "(no log)", source);
    free(log);
    return VDBS_ERR_GPU;
}

vdbs_status vdbs_gpu_program_create(vdbs_gpu *gpu, const vdbs_shader_source *source,
                                    const char *defines, vdbs_gpu_program *program, vdbs_error *err)
{
    (void)gpu;
    program->id = 0;
    if (!source || !source->text)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "no shader source");
    const char *name = source->name ? source->name : "shader";
    clear_gl_errors();

    char *text = assemble_source(source, defines);
    if (!text)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory building shader %s", name);

    vdbs_status st = VDBS_OK;
    GLuint shader = glCreateShader(GL_COMPUTE_SHADER);
    GLuint prog = 0;
    if (!shader) {
        st = vdbs_error_set(err, VDBS_ERR_GPU, "%s: glCreateShader failed (%s)", name,
                            gl_error_name(glGetError()));
        goto done;
    }
    const GLchar *pieces[1] = {text};
    glShaderSource(shader, 1, pieces, NULL);
    glCompileShader(shader);
    GLint ok = GL_FALSE;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        st = build_failed(err, "compiling", name, get_log(shader, 0), source);
        goto done;
    }

    prog = glCreateProgram();
    glAttachShader(prog, shader);
    glLinkProgram(prog);
    /* The program keeps the compiled code; the shader object is no longer needed. */
    glDetachShader(prog, shader);
    glGetProgramiv(prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        st = build_failed(err, "linking", name, get_log(prog, 1), source);
        goto done;
    }
    GLenum gl_err = glGetError();
    if (gl_err != GL_NO_ERROR) {
        st = vdbs_error_set(err, VDBS_ERR_GPU, "building shader %s: %s", name,
                            gl_error_name(gl_err));
        goto done;
    }
    program->id = prog;

done:
    if (st != VDBS_OK && prog)
        glDeleteProgram(prog);
    if (shader)
        glDeleteShader(shader);
    free(text);
    return st;
}

void vdbs_gpu_program_destroy(vdbs_gpu *gpu, vdbs_gpu_program program)
{
    (void)gpu;
    if (program.id)
        glDeleteProgram(program.id);
}

/* ---- buffers ---- */

vdbs_status vdbs_gpu_buffer_create(vdbs_gpu *gpu, size_t size, const void *data,
                                   vdbs_gpu_buffer *buffer, vdbs_error *err)
{
    buffer->id = 0;
    if ((uint64_t)size > (uint64_t)gpu->info.max_ssbo_bytes)
        return vdbs_error_set(err, VDBS_ERR_GPU,
                              "a GPU buffer of %zu bytes exceeds this GPU's shader storage "
                              "limit of %" PRId64 " bytes (%s); use --backend cpu",
                              size, gpu->info.max_ssbo_bytes, gpu->info.renderer);
    /* GL refuses empty buffers, and an empty grid is legitimate input. */
    GLsizeiptr gl_size = size > 0 ? (GLsizeiptr)size : 4;
    clear_gl_errors();
    GLuint buf = 0;
    glCreateBuffers(1, &buf);
    /* Immutable storage: the size is fixed, uploads through glNamedBufferSubData stay allowed. */
    glNamedBufferStorage(buf, gl_size, size > 0 ? data : NULL, GL_DYNAMIC_STORAGE_BIT);
    if (!data || size == 0)
        glClearNamedBufferData(buf, GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, NULL);
    GLenum gl_err = glGetError();
    if (gl_err != GL_NO_ERROR) {
        glDeleteBuffers(1, &buf);
        return vdbs_error_set(err, gl_err == GL_OUT_OF_MEMORY ? VDBS_ERR_NOMEM : VDBS_ERR_GPU,
                              "creating a GPU buffer of %zu bytes failed (%s)", size,
                              gl_error_name(gl_err));
    }
    buffer->id = buf;
    return VDBS_OK;
}

vdbs_status vdbs_gpu_buffer_read(vdbs_gpu *gpu, vdbs_gpu_buffer buffer, size_t offset, size_t size,
                                 void *dst, vdbs_error *err)
{
    (void)gpu;
    if (size == 0)
        return VDBS_OK;
    clear_gl_errors();
    GLint64 buffer_size = 0;
    glGetNamedBufferParameteri64v(buffer.id, GL_BUFFER_SIZE, &buffer_size);
    if (offset > (uint64_t)buffer_size || size > (uint64_t)buffer_size - offset)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "reading %zu bytes at offset %zu of GPU buffer %u (%" PRId64
                              " bytes) is out of range",
                              size, offset, buffer.id, (int64_t)buffer_size);
    /* Shader writes become visible to glGetBufferSubData only after this barrier. */
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(buffer.id, (GLintptr)offset, (GLsizeiptr)size, dst);
    GLenum gl_err = glGetError();
    if (gl_err != GL_NO_ERROR)
        return vdbs_error_set(err, VDBS_ERR_GPU, "reading GPU buffer %u failed (%s)", buffer.id,
                              gl_error_name(gl_err));
    return VDBS_OK;
}

void vdbs_gpu_buffer_destroy(vdbs_gpu *gpu, vdbs_gpu_buffer buffer)
{
    (void)gpu;
    if (buffer.id)
        glDeleteBuffers(1, &buffer.id);
}

void vdbs_gpu_buffer_bind(vdbs_gpu *gpu, vdbs_gpu_buffer buffer, unsigned int binding)
{
    (void)gpu;
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer.id);
}

/* ---- dispatch ---- */

vdbs_status vdbs_gpu_dispatch_items(vdbs_gpu *gpu, vdbs_gpu_program program, uint64_t count,
                                    unsigned int local_size, uint64_t chunk_items,
                                    void (*progress)(void *user, uint64_t done, uint64_t total),
                                    void *user, vdbs_error *err)
{
    if (local_size == 0)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "dispatch with a local size of 0");
    if (count == 0)
        return VDBS_OK;
    /* Item indices are 32-bit uints in GLSL, including the padding of the last group. */
    if (count > (uint64_t)UINT32_MAX - local_size)
        return vdbs_error_set(
            err, VDBS_ERR_GPU,
            "%" PRIu64 " work items are too many for one GPU dispatch; use --backend cpu", count);
    clear_gl_errors();

    GLint group_size[3] = {0, 0, 0};
    glGetProgramiv(program.id, GL_COMPUTE_WORK_GROUP_SIZE, group_size);
    if (glGetError() != GL_NO_ERROR)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "program %u is not a linked compute program",
                              program.id);
    if ((unsigned)group_size[0] != local_size || group_size[1] != 1 || group_size[2] != 1)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "dispatch with local size %u, but the shader declares %dx%dx%d",
                              local_size, group_size[0], group_size[1], group_size[2]);

    /* Whole groups per chunk: a partial group would spill into the next chunk's items. */
    uint64_t max_groups =
        gpu->info.max_work_group_count[0] > 0 ? (uint64_t)gpu->info.max_work_group_count[0] : 65535;
    uint64_t groups_per_chunk = chunk_items > 0 ? chunk_items / local_size : max_groups;
    if (groups_per_chunk < 1)
        groups_per_chunk = 1;
    if (groups_per_chunk > max_groups)
        groups_per_chunk = max_groups;
    uint64_t chunk = groups_per_chunk * local_size;

    GLint loc_offset = glGetUniformLocation(program.id, "u_item_offset");
    GLint loc_count = glGetUniformLocation(program.id, "u_item_count");
    if (loc_offset < 0 && count > chunk)
        return vdbs_error_set(err, VDBS_ERR_INTERNAL,
                              "%" PRIu64 " items need several dispatches of %" PRIu64
                              ", but the shader has no uniform uint u_item_offset",
                              count, chunk);
    if (loc_count >= 0)
        glProgramUniform1ui(program.id, loc_count, (GLuint)count);
    glUseProgram(program.id);

    for (uint64_t done = 0; done < count;) {
        uint64_t n = count - done < chunk ? count - done : chunk;
        if (loc_offset >= 0)
            glProgramUniform1ui(program.id, loc_offset, (GLuint)done);
        glDispatchCompute((GLuint)((n + local_size - 1) / local_size), 1, 1);
        done += n;
        if (done < count)
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
        GLenum gl_err = glGetError();
        if (gl_err != GL_NO_ERROR) {
            glFinish();
            return vdbs_error_set(
                err, VDBS_ERR_GPU, "GPU dispatch failed at item %" PRIu64 " (%s)%s", done - n,
                gl_error_name(gl_err),
                gl_err == GL_INVALID_OPERATION ? "; are u_item_offset and u_item_count uint?" : "");
        }
        if (progress) {
            /* Waiting makes the reported progress real, not just queued work. */
            glFinish();
            progress(user, done, count);
        } else {
            /* Submitting each chunk keeps single submissions short (driver watchdogs). */
            glFlush();
        }
    }
    /* Whatever the caller does next (reads, draws, another dispatch) sees the writes. */
    glMemoryBarrier(GL_ALL_BARRIER_BITS);
    glFinish();
    GLenum gl_err = glGetError();
    if (gl_err != GL_NO_ERROR)
        return vdbs_error_set(err, VDBS_ERR_GPU, "GPU dispatch failed (%s)", gl_error_name(gl_err));
    return VDBS_OK;
}
