/* The command-line option parser: argv vectors split from the input at NUL or newline bytes,
 * parsed by bake's and render's options (with every solver's own flags) into a scene as the
 * commands do, then the value parsers the commands call (--size, --camera, --s1).
 * Arguments naming files outside the working folder are dropped (--scene /dev/zero). */
#include "fuzz_util.h"
#include "options.h"
#include "vdbscatter/scene.h"

static const vdbs_arg_option common[] = {
    VDBS_OPTIONS_COMMON,
    {"--camera", VDBS_ARG_VALUE},
    {"--size", VDBS_ARG_VALUE},
    {"--method", VDBS_ARG_VALUE},
    {"--from-levelset", VDBS_ARG_FLAG},
    {"--half", VDBS_ARG_FLAG},
    {"--tolerance", VDBS_ARG_VALUE},
    {"--mode", VDBS_ARG_VALUE},
};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static vdbs_arg_option table[VDBS_OPTIONS_MAX];
    static int ready = 0;
    if (!ready) {
        memcpy(table, common, sizeof common);
        vdbs_options_add_solver_flags(table, (int)(sizeof common / sizeof *common),
                                      VDBS_OPTIONS_MAX);
        ready = 1;
    }
    char *text = malloc(size + 1);
    char **argv = malloc((size + 1) * sizeof *argv);
    vdbs_scene *scene = malloc(sizeof *scene);
    if (!text || !argv || !scene)
        abort();
    memcpy(text, data, size);
    text[size] = '\0';
    int argc = 0;
    for (char *p = text, *start = text; p <= text + size; ++p) {
        if (*p == '\n' || *p == '\0') {
            *p = '\0';
            if (!strchr(start, '/'))
                argv[argc++] = start;
            start = p + 1;
        }
    }
    vdbs_options_args args;
    vdbs_error err;
    vdbs_status st = vdbs_options_parse(argc, argv, table, &args, &err);
    fuzz_check_error(st, &err, "vdbs_options_parse");
    if (st == VDBS_OK) {
        st = vdbs_options_build_scene(&args, scene, size % 2, &err);
        fuzz_check_error(st, &err, "vdbs_options_build_scene");
        (void)vdbs_options_scene_flags(&args);
        int march = 0, oversample = 0, w = 0, h = 0;
        st = vdbs_options_s1(&args, &march, &oversample, &err);
        fuzz_check_error(st, &err, "vdbs_options_s1");
        const char *v = vdbs_options_value(&args, "--size");
        if (v) {
            st = vdbs_options_size(v, &w, &h, &err);
            fuzz_check_error(st, &err, "vdbs_options_size");
            if (st == VDBS_OK && (w < 1 || h < 1 || w > 16384 || h > 16384)) {
                fprintf(stderr, "fuzz: --size %s accepted as %dx%d\n", v, w, h);
                abort();
            }
        }
        if ((v = vdbs_options_value(&args, "--camera"))) {
            vdbs_camera camera;
            st = vdbs_options_camera(v, &camera, &err);
            fuzz_check_error(st, &err, "vdbs_options_camera");
        }
    }
    free(scene);
    free(argv);
    free(text);
    return 0;
}
