/* GPU module: EGL context, program building with mapped error lines, buffers and
 * chunked dispatch (llvmpipe on machines without a GPU). */
#include "testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/gpu.h"

/* Each test gets its own context, which also exercises repeated create/destroy. */
static int setup_gpu(void **state)
{
    vdbs_gpu *gpu = NULL;
    vdbs_error err = {{0}};
    vdbs_status st = vdbs_gpu_create(&gpu, &err);
    if (st != VDBS_OK) {
        fprintf(stderr, "vdbs_gpu_create: %s\n", err.message);
        return -1;
    }
    *state = gpu;
    return 0;
}

static int teardown_gpu(void **state)
{
    vdbs_gpu_destroy(*state);
    return 0;
}

static vdbs_shader_source make_source(const char *name, const char *text, const char *const *files,
                                      int file_count)
{
    vdbs_shader_source s = {name, text, files, file_count};
    return s;
}

static void test_context_info(void **state)
{
    const vdbs_gpu_info *info = vdbs_gpu_get_info(*state);
    int major = 0, minor = 0;
    assert_int_equal(sscanf(info->version, "%d.%d", &major, &minor), 2);
    assert_true(major * 10 + minor >= 43);
    int glsl_major = 0, glsl_minor = 0;
    assert_int_equal(sscanf(info->glsl_version, "%d.%d", &glsl_major, &glsl_minor), 2);
    assert_true(glsl_major * 100 + glsl_minor >= 430);
    assert_true(strcmp(info->platform, "device") == 0 ||
                strcmp(info->platform, "surfaceless") == 0 ||
                strcmp(info->platform, "default") == 0);
    assert_true(info->vendor[0] != '\0');
    assert_true(info->renderer[0] != '\0');
    /* Mesa names the profile in its version string. */
    if (strstr(info->renderer, "llvmpipe")) {
        assert_non_null(strstr(info->version, "Core Profile"));
        assert_true(info->is_software);
    }
    /* GL 4.3 minimums. */
    assert_true(info->max_ssbo_bytes >= (int64_t)1 << 24);
    assert_true(info->max_work_group_invocations >= 1024);
    for (int i = 0; i < 3; i++)
        assert_true(info->max_work_group_count[i] >= 65535);

    int hw = vdbs_gpu_hardware_available();
    assert_true(hw == 0 || hw == 1);
    if (!hw)
        assert_true(info->is_software);
    printf("platform %s, renderer %s, version %s, hardware device available: %d\n", info->platform,
           info->renderer, info->version, hw);
}

static const char *const items_text =
    "#version 430\n"
    "layout(local_size_x = LOCAL_SIZE) in;\n"
    "layout(std430, binding = 0) buffer Out { uint values[]; };\n"
    "uniform uint u_item_offset;\n"
    "uniform uint u_item_count;\n"
    "void main()\n"
    "{\n"
    "    uint i = u_item_offset + gl_GlobalInvocationID.x;\n"
    "    if (i >= u_item_count)\n"
    "        return;\n"
    "    /* An item processed twice (or never) leaves a wrong value. */\n"
    "    values[i] = values[i] == SENTINEL ? i * 2654435761u ^ (i >> 3u) : 0xFFFFFFFFu;\n"
    "}\n";

#define SENTINEL 0xDEADBEEFu

static uint32_t item_value(uint32_t i)
{
    return (i * 2654435761u) ^ (i >> 3u);
}

typedef struct progress_log {
    int calls;
    uint64_t last_done;
    uint64_t max_step;
    int monotonic;
    uint64_t total;
} progress_log;

static void record_progress(void *user, uint64_t done, uint64_t total)
{
    progress_log *log = user;
    if (done <= log->last_done)
        log->monotonic = 0;
    if (done - log->last_done > log->max_step)
        log->max_step = done - log->last_done;
    log->last_done = done;
    log->total = total;
    log->calls++;
}

/* Runs items_text over `count` items in a buffer `pad` items longer than needed and
 * checks every value, and that the padding is untouched. */
static void run_items(vdbs_gpu *gpu, uint64_t count, unsigned local_size, uint64_t chunk,
                      int expected_chunks)
{
    static const char *const files[] = {"items.comp"};
    vdbs_shader_source src = make_source("items.comp", items_text, files, 1);
    char defines[128];
    snprintf(defines, sizeof defines, "#define LOCAL_SIZE %u\n#define SENTINEL 0x%Xu\n", local_size,
             SENTINEL);
    vdbs_error err = {{0}};
    vdbs_gpu_program program = {0};
    vdbs_status st = vdbs_gpu_program_create(gpu, &src, defines, &program, &err);
    if (st != VDBS_OK)
        fprintf(stderr, "%s\n", err.message);
    assert_int_equal(st, VDBS_OK);
    assert_true(program.id != 0);

    const size_t pad = 1000;
    size_t n = (size_t)count + pad;
    uint32_t *data = malloc(n * sizeof *data);
    assert_non_null(data);
    for (size_t i = 0; i < n; i++)
        data[i] = SENTINEL;
    vdbs_gpu_buffer buffer = {0};
    st = vdbs_gpu_buffer_create(gpu, n * sizeof *data, data, &buffer, &err);
    assert_int_equal(st, VDBS_OK);
    vdbs_gpu_buffer_bind(gpu, buffer, 0);

    progress_log log = {0, 0, 0, 1, 0};
    st = vdbs_gpu_dispatch_items(gpu, program, count, local_size, chunk, record_progress, &log,
                                 &err);
    if (st != VDBS_OK)
        fprintf(stderr, "%s\n", err.message);
    assert_int_equal(st, VDBS_OK);
    assert_int_equal(log.calls, expected_chunks);
    assert_true(log.monotonic);
    assert_true(log.last_done == count);
    assert_true(log.total == count);
    if (chunk > 0)
        assert_true(log.max_step <= (chunk > local_size ? chunk : local_size));

    memset(data, 0, n * sizeof *data);
    st = vdbs_gpu_buffer_read(gpu, buffer, 0, n * sizeof *data, data, &err);
    assert_int_equal(st, VDBS_OK);
    size_t wrong = 0;
    for (size_t i = 0; i < (size_t)count; i++)
        wrong += data[i] != item_value((uint32_t)i);
    for (size_t i = (size_t)count; i < n; i++)
        wrong += data[i] != SENTINEL;
    assert_int_equal(wrong, 0);

    /* A read at an offset returns the same bytes. */
    if (count >= 2) {
        uint32_t tail[4];
        size_t at = (size_t)count - 2;
        st = vdbs_gpu_buffer_read(gpu, buffer, at * sizeof(uint32_t), sizeof tail, tail, &err);
        assert_int_equal(st, VDBS_OK);
        assert_int_equal(tail[0], item_value((uint32_t)at));
        assert_int_equal(tail[1], item_value((uint32_t)at + 1));
        assert_int_equal(tail[2], SENTINEL);
    }

    free(data);
    vdbs_gpu_buffer_destroy(gpu, buffer);
    vdbs_gpu_program_destroy(gpu, program);
}

static void test_dispatch_million_items_in_chunks(void **state)
{
    /* 100000 rounds down to 1562 groups of 64 = 99968 items: 11 chunks. */
    run_items(*state, 1000003, 64, 100000, 11);
}

static void test_dispatch_chunk_sizes(void **state)
{
    run_items(*state, 1000, 64, 0, 1);   /* no chunk limit: one dispatch */
    run_items(*state, 1000, 64, 1, 16);  /* below one group: one group per chunk */
    run_items(*state, 1000, 32, 96, 11); /* exact multiple of the group */
    run_items(*state, 1, 256, 0, 1);     /* one item, mostly idle group */
    /* The group count limit (65535 on llvmpipe) splits a chunk of 70000 groups of 1. */
    const vdbs_gpu_info *info = vdbs_gpu_get_info(*state);
    run_items(*state, 70000, 1, 70000, info->max_work_group_count[0] < 70000 ? 2 : 1);
}

static void test_dispatch_errors(void **state)
{
    vdbs_gpu *gpu = *state;
    static const char *const files[] = {"plain.comp"};
    /* No u_item_offset: fine in one dispatch, refused when several are needed. */
    vdbs_shader_source src =
        make_source("plain.comp",
                    "#version 430\n"
                    "layout(local_size_x = 64) in;\n"
                    "layout(std430, binding = 0) buffer Out { uint values[]; };\n"
                    "void main() { values[gl_GlobalInvocationID.x] = 7u; }\n",
                    files, 1);
    vdbs_error err = {{0}};
    vdbs_gpu_program program = {0};
    assert_int_equal(vdbs_gpu_program_create(gpu, &src, NULL, &program, &err), VDBS_OK);
    vdbs_gpu_buffer buffer = {0};
    assert_int_equal(vdbs_gpu_buffer_create(gpu, 1024 * 4, NULL, &buffer, &err), VDBS_OK);
    vdbs_gpu_buffer_bind(gpu, buffer, 0);

    uint32_t values[1024];
    assert_int_equal(vdbs_gpu_buffer_read(gpu, buffer, 0, sizeof values, values, &err), VDBS_OK);
    for (int i = 0; i < 1024; i++)
        assert_int_equal(values[i], 0); /* NULL data: zeroed */

    assert_int_equal(vdbs_gpu_dispatch_items(gpu, program, 1024, 64, 0, NULL, NULL, &err), VDBS_OK);
    assert_int_equal(vdbs_gpu_buffer_read(gpu, buffer, 0, sizeof values, values, &err), VDBS_OK);
    for (int i = 0; i < 1024; i++)
        assert_int_equal(values[i], 7);

    err.message[0] = '\0';
    assert_int_equal(vdbs_gpu_dispatch_items(gpu, program, 1024, 64, 128, NULL, NULL, &err),
                     VDBS_ERR_INTERNAL);
    assert_non_null(strstr(err.message, "u_item_offset"));

    /* local_size must be the shader's. */
    err.message[0] = '\0';
    assert_int_equal(vdbs_gpu_dispatch_items(gpu, program, 1024, 32, 0, NULL, NULL, &err),
                     VDBS_ERR_INTERNAL);
    assert_non_null(strstr(err.message, "local size"));

    /* Nothing to do is not an error. */
    assert_int_equal(vdbs_gpu_dispatch_items(gpu, program, 0, 64, 0, NULL, NULL, &err), VDBS_OK);

    /* Reads past the end fail cleanly. */
    err.message[0] = '\0';
    assert_int_not_equal(vdbs_gpu_buffer_read(gpu, buffer, 4000, 100, values, &err), VDBS_OK);
    assert_non_null(strstr(err.message, "out of range"));

    vdbs_gpu_buffer_destroy(gpu, buffer);
    vdbs_gpu_program_destroy(gpu, program);
}

/* Builds `text` expecting failure; returns the message. */
static const char *build_failure(vdbs_gpu *gpu, const vdbs_shader_source *src, const char *defines)
{
    static vdbs_error err;
    vdbs_gpu_program program = {123};
    err.message[0] = '\0';
    vdbs_status st = vdbs_gpu_program_create(gpu, src, defines, &program, &err);
    assert_int_equal(st, VDBS_ERR_GPU);
    assert_int_equal(program.id, 0);
    printf("-- expected build failure:\n%s\n", err.message);
    return err.message;
}

static void test_compile_error_line(void **state)
{
    vdbs_gpu *gpu = *state;
    static const char *const files[] = {"myfile.comp"};
    vdbs_shader_source src =
        make_source("myfile.comp",
                    "// a comment before #version is allowed\n"               /* 1 */
                    "#version 430\n"                                          /* 2 */
                    "layout(local_size_x = 1) in;\n"                          /* 3 */
                    "layout(std430, binding = 0) buffer Out { uint v[]; };\n" /* 4 */
                    "void main()\n"                                           /* 5 */
                    "{\n"                                                     /* 6 */
                    "    v[0] = 1u;\n"                                        /* 7 */
                    "    v[1] = undefined_variable;\n"                        /* 8 */
                    "}\n",                                                    /* 9 */
                    files, 1);
    const char *msg = build_failure(gpu, &src, NULL);
    assert_non_null(strstr(msg, "myfile.comp:8: error"));
    /* Inserted defines must not shift the numbering. */
    msg = build_failure(gpu, &src, "#define A 1\n#define B 2\n#define C 3\n");
    assert_non_null(strstr(msg, "myfile.comp:8: error"));
    /* Defines without a final newline work as well. */
    msg = build_failure(gpu, &src, "#define A 1");
    assert_non_null(strstr(msg, "myfile.comp:8: error"));
    /* An error inside the defines is reported as such: the place is ours, the wording the
     * driver's (Mesa: "preprocessor error: #error bad define", NVIDIA: "error C0000: bad
     * define"). */
    msg = build_failure(gpu, &src, "#define A 1\n#error bad define\n");
    const char *at = strstr(msg, "<defines>:2: ");
    assert_non_null(at);
    assert_non_null(strstr(at, "bad define"));
}

static void test_compile_error_in_included_file(void **state)
{
    vdbs_gpu *gpu = *state;
    static const char *const files[] = {"main.comp", "helper.glsl"};
    /* What the embedder makes of main.comp with `#include "helper.glsl"` on its line 3. */
    vdbs_shader_source src = make_source("main.comp",
                                         "#version 430\n"
                                         "#line 2 0\n"
                                         "layout(local_size_x = 1) in;\n"
                                         "#line 1 1\n"
                                         "// helper line 1\n"
                                         "uint helper() { return missing_thing; }\n"
                                         "#line 4 0\n"
                                         "layout(std430, binding = 0) buffer Out { uint v[]; };\n"
                                         "void main() { v[0] = helper(); }\n",
                                         files, 2);
    const char *msg = build_failure(gpu, &src, "#define X 1\n");
    assert_non_null(strstr(msg, "helper.glsl:2: error"));
    assert_null(strstr(msg, "main.comp:"));

    /* After the include the numbering is the main file's again. */
    vdbs_shader_source src2 = make_source("main.comp",
                                          "#version 430\n"
                                          "#line 2 0\n"
                                          "layout(local_size_x = 1) in;\n"
                                          "#line 1 1\n"
                                          "// helper line 1\n"
                                          "uint helper() { return 3u; }\n"
                                          "#line 4 0\n"
                                          "layout(std430, binding = 0) buffer Out { uint v[]; };\n"
                                          "void main() { v[0] = helper() + nonsense; }\n",
                                          files, 2);
    msg = build_failure(gpu, &src2, NULL);
    assert_non_null(strstr(msg, "main.comp:5: error"));
    assert_null(strstr(msg, "helper.glsl:"));

    /* Mesa's preprocessor loses a line for a macro call spanning lines; the directive
     * after the include restores the numbering. */
    vdbs_shader_source src3 = make_source("main.comp",
                                          "#version 430\n"
                                          "#line 2 0\n"
                                          "layout(local_size_x = 1) in;\n"
                                          "#line 1 1\n"
                                          "#define M(x) (x)\n"
                                          "float a = M(1.0 +\n"
                                          "            2.0);\n"
                                          "#line 4 0\n"
                                          "layout(std430, binding = 0) buffer Out { uint v[]; };\n"
                                          "void main() { v[0] = 1u + after_macro; }\n",
                                          files, 2);
    msg = build_failure(gpu, &src3, "#define X 1\n");
    assert_non_null(strstr(msg, "main.comp:5: error"));

    /* An include in a skipped branch: its directives are never applied, and the one the
     * embedder puts after #endif restores the numbering. */
    vdbs_shader_source src4 = make_source("main.comp",
                                          "#version 430\n"
                                          "#line 2 0\n"
                                          "layout(local_size_x = 1) in;\n"
                                          "#ifdef NOT_DEFINED\n"
                                          "#line 1 1\n"
                                          "uint helper() { return 1u; }\n"
                                          "#line 5 0\n"
                                          "#endif\n"
                                          "#line 6 0\n"
                                          "layout(std430, binding = 0) buffer Out { uint v[]; };\n"
                                          "void main() { v[0] = skipped_branch; }\n",
                                          files, 2);
    msg = build_failure(gpu, &src4, NULL);
    assert_non_null(strstr(msg, "main.comp:7: error"));
}

static void test_buffer_limits(void **state)
{
    vdbs_gpu *gpu = *state;
    const vdbs_gpu_info *info = vdbs_gpu_get_info(gpu);
    vdbs_error err = {{0}};
    vdbs_gpu_buffer buffer = {77};
    vdbs_status st =
        vdbs_gpu_buffer_create(gpu, (size_t)info->max_ssbo_bytes + 1, NULL, &buffer, &err);
    assert_int_equal(st, VDBS_ERR_GPU);
    assert_int_equal(buffer.id, 0);
    assert_non_null(strstr(err.message, "--backend cpu"));
    printf("-- expected buffer failure: %s\n", err.message);

    /* An empty buffer is legitimate (an empty grid). */
    st = vdbs_gpu_buffer_create(gpu, 0, NULL, &buffer, &err);
    assert_int_equal(st, VDBS_OK);
    assert_true(buffer.id != 0);
    vdbs_gpu_buffer_destroy(gpu, buffer);
}

static void test_embedded_table(void **state)
{
    (void)state;
    assert_null(vdbs_shader_find("no_such_shader.comp"));
    assert_null(vdbs_shader_find(""));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_context_info, setup_gpu, teardown_gpu),
        cmocka_unit_test_setup_teardown(test_dispatch_million_items_in_chunks, setup_gpu,
                                        teardown_gpu),
        cmocka_unit_test_setup_teardown(test_dispatch_chunk_sizes, setup_gpu, teardown_gpu),
        cmocka_unit_test_setup_teardown(test_dispatch_errors, setup_gpu, teardown_gpu),
        cmocka_unit_test_setup_teardown(test_compile_error_line, setup_gpu, teardown_gpu),
        cmocka_unit_test_setup_teardown(test_compile_error_in_included_file, setup_gpu,
                                        teardown_gpu),
        cmocka_unit_test_setup_teardown(test_buffer_limits, setup_gpu, teardown_gpu),
        cmocka_unit_test(test_embedded_table),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
