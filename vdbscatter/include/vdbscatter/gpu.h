/* Headless OpenGL compute through EGL (no window, no display server).
 * With no GPU, Mesa's llvmpipe runs the same shaders on the CPU. */
#ifndef VDBSCATTER_GPU_H
#define VDBSCATTER_GPU_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdbs_gpu_info {
    char platform[32];  /* "device", "surfaceless" or "default": the EGL platform that worked;
                         "window" for an adopted context */
    char vendor[128];   /* GL_VENDOR */
    char renderer[256]; /* GL_RENDERER */
    char version[128];  /* GL_VERSION */
    char glsl_version[64];
    int is_software;        /* llvmpipe, softpipe, swrast or an EGL_MESA_device_software device */
    int64_t max_ssbo_bytes; /* GL_MAX_SHADER_STORAGE_BLOCK_SIZE */
    int max_work_group_invocations; /* GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS */
    int max_work_group_count[3];
} vdbs_gpu_info;

typedef struct vdbs_gpu vdbs_gpu;

/* GL object names, typed so that a buffer cannot be passed where a program is expected;
 * id 0 is "none". */
typedef struct vdbs_gpu_program {
    unsigned id;
} vdbs_gpu_program;
typedef struct vdbs_gpu_buffer {
    unsigned id;
} vdbs_gpu_buffer;

/* Creates an OpenGL 4.3+ core context without any surface: EGL device platform
 * first (hardware devices before software ones), then surfaceless Mesa, then the
 * default display. Buffers use direct state access, so GL 4.5 or
 * GL_ARB_direct_state_access is required too. Fails with VDBS_ERR_GPU and a message
 * saying what each attempt answered. The context is current on the calling thread
 * until vdbs_gpu_destroy; every other vdbs_gpu_* call must come from that thread.
 * Creating and destroying contexts is not thread-safe (EGL displays are shared and
 * reference-counted across vdbs_gpu objects). */
vdbs_status vdbs_gpu_create(vdbs_gpu **out, vdbs_error *err);
/* Wraps the GL context current on the calling thread (a window's, e.g. GLFW's) instead
 * of creating one; info.platform is "window". Destroying it leaves the context alone.
 * Errors: no current context of version 4.3 with direct state access. */
vdbs_status vdbs_gpu_adopt_current(vdbs_gpu **out, vdbs_error *err);
void vdbs_gpu_destroy(vdbs_gpu *gpu);
const vdbs_gpu_info *vdbs_gpu_get_info(const vdbs_gpu *gpu);

/* Whether EGL offers a hardware device, without creating a context (for --backend auto).
 * Returns 0 when there is none or EGL is unusable. */
int vdbs_gpu_hardware_available(void);

/* A shader embedded at build time from shaders/: `text` is the whole source with
 * every `#include "file"` expanded and `#line L F` directives where F indexes `files`
 * (files[0] is the shader itself). Tests may build their own. */
typedef struct vdbs_shader_source {
    const char *name; /* file name in shaders/, e.g. "single_scatter.comp" */
    const char *text;
    const char *const *files;
    int file_count;
} vdbs_shader_source;

/* Embedded shader by file name, or NULL. */
const vdbs_shader_source *vdbs_shader_find(const char *name);

/* Compiles and links a compute program. `defines` (may be NULL) is inserted after the
 * #version line, e.g. "#define LOCAL_SIZE 64\n". Compile errors come back as
 * VDBS_ERR_GPU with each message rewritten as "file:line: message" (one per line,
 * errors only when there are any; "<defines>:line:" for errors in `defines`).
 * The `#line` directives are interpreted here, not by the driver: Mesa drops their
 * file numbers from most messages. */
vdbs_status vdbs_gpu_program_create(vdbs_gpu *gpu, const vdbs_shader_source *source,
                                    const char *defines, vdbs_gpu_program *program,
                                    vdbs_error *err);
void vdbs_gpu_program_destroy(vdbs_gpu *gpu, vdbs_gpu_program program);

/* Shader storage buffers (immutable storage, updatable with glNamedBufferSubData).
 * `data` may be NULL (contents zeroed); size 0 makes a 4-byte buffer. Sizes above
 * info.max_ssbo_bytes (GL_MAX_SHADER_STORAGE_BLOCK_SIZE; 128 MiB on llvmpipe, though it
 * tolerates more) are refused with VDBS_ERR_GPU and a message suggesting --backend cpu.
 * buffer_read waits for earlier shader writes; reads beyond the end fail. */
vdbs_status vdbs_gpu_buffer_create(vdbs_gpu *gpu, size_t size, const void *data,
                                   vdbs_gpu_buffer *buffer, vdbs_error *err);
vdbs_status vdbs_gpu_buffer_read(vdbs_gpu *gpu, vdbs_gpu_buffer buffer, size_t offset, size_t size,
                                 void *dst, vdbs_error *err);
void vdbs_gpu_buffer_destroy(vdbs_gpu *gpu, vdbs_gpu_buffer buffer);
void vdbs_gpu_buffer_bind(vdbs_gpu *gpu, vdbs_gpu_buffer buffer, unsigned int binding);

/* Runs `program` over `count` work items with work groups of `local_size` invocations
 * (the shader's local_size_x), in chunks that respect the work-group count limit:
 * before each chunk the uniform `uint u_item_offset` (when present) is set to the
 * first item of the chunk, so an invocation's item is
 * u_item_offset + gl_GlobalInvocationID.x (items >= u_item_count must do nothing;
 * u_item_count is set too). Calls progress(user, done, count) after each chunk when
 * not NULL; waits for completion (glFinish) before returning.
 * `local_size` must equal the shader's declared size (x, 1, 1), else
 * VDBS_ERR_INTERNAL. A chunk is `chunk_items` rounded down to whole groups (at least
 * one group; 0 means as large as the limit allows), so every item runs exactly once.
 * Without u_item_offset, a count that needs several chunks is VDBS_ERR_INTERNAL.
 * Both uniforms are GLSL uints, so count must stay below 2^32 - local_size. Chunks
 * are separated by shader-storage and image barriers; with a progress callback each
 * chunk is finished (glFinish) before the callback, so the progress is real. */
vdbs_status vdbs_gpu_dispatch_items(vdbs_gpu *gpu, vdbs_gpu_program program, uint64_t count,
                                    unsigned int local_size, uint64_t chunk_items,
                                    void (*progress)(void *user, uint64_t done, uint64_t total),
                                    void *user, vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
