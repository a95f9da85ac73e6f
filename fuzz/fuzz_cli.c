/* The command-line option parser: argv vectors split from the input at NUL or newline bytes,
 * parsed by bake's and render's options (with every solver's own flags) into a scene as the
 * commands do, then the value parsers the commands call (--size, --camera, --s1).
 * Arguments naming files outside the working folder are dropped (--scene /dev/zero). */
#include "fuzz_util.h"
#include "options.h"
#include "solver_flags.h"
#include "vdbscatter/scene.h"

static const cli_option common[] = {
    CLI_COMMON_OPTIONS,         {"--camera", CLI_VALUE},       {"--size", CLI_VALUE},
    {"--method", CLI_VALUE},    {"--from-levelset", CLI_FLAG}, {"--half", CLI_FLAG},
    {"--tolerance", CLI_VALUE}, {"--mode", CLI_VALUE},
};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static cli_option table[CLI_MAX_OPTIONS];
    static int ready = 0;
    if (!ready) {
        memcpy(table, common, sizeof common);
        cli_solver_flags_add(table, (int)(sizeof common / sizeof *common), CLI_MAX_OPTIONS);
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
    cli_args args;
    vdbs_error err;
    vdbs_status st = cli_parse(argc, argv, table, &args, &err);
    fuzz_check_error(st, &err, "cli_parse");
    if (st == VDBS_OK) {
        st = cli_build_scene(&args, scene, size % 2, &err);
        fuzz_check_error(st, &err, "cli_build_scene");
        (void)cli_scene_flags(&args);
        int march = 0, oversample = 0, w = 0, h = 0;
        st = cli_s1_options(&args, &march, &oversample, &err);
        fuzz_check_error(st, &err, "cli_s1_options");
        const char *v = cli_value(&args, "--size");
        if (v) {
            st = cli_size(v, &w, &h, &err);
            fuzz_check_error(st, &err, "cli_size");
            if (st == VDBS_OK && (w < 1 || h < 1 || w > 16384 || h > 16384)) {
                fprintf(stderr, "fuzz: --size %s accepted as %dx%d\n", v, w, h);
                abort();
            }
        }
        if ((v = cli_value(&args, "--camera"))) {
            vdbs_camera camera;
            st = cli_camera(v, &camera, &err);
            fuzz_check_error(st, &err, "cli_camera");
        }
    }
    free(scene);
    free(argv);
    free(text);
    return 0;
}
