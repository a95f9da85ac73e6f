/* vdbscatter compare A B: error metrics of image A against the reference image B. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "options.h"
#include "vdbscatter/image.h"

static const char help[] =
    "usage: vdbscatter compare A B [--json] [--mask-below V]\n"
    "\n"
    "Compares image A with the reference image B (OpenEXR or PNG, same size).\n"
    "Over all pixels and RGB channels:\n"
    "  relrmse      sqrt(mean((A-B)^2)) / sqrt(mean(B^2))\n"
    "  mean_rel     mean of |A-B| / (|B| + 1e-3 mean(|B|))\n"
    "  p99_rel      99th percentile of the same\n"
    "  samples      pixel-channel values compared\n"
    "When either EXR carries se.R, se.G, se.B (standard errors of Monte-Carlo pixels;\n"
    "an image without them counts as exact, se = 0):\n"
    "  noise_share  mean(se_A^2 + se_B^2) / mean((A-B)^2): about 1 when the difference\n"
    "               is noise alone, much below 1 when it is bias\n"
    "  z_mean       mean of z = (A-B) / sqrt(se_A^2 + se_B^2) (about 0 without bias)\n"
    "  z_rms        rms of z (about 1 without bias)\n"
    "  z_samples    values that entered z (those with a non-zero se)\n"
    "and for each image with se channels:\n"
    "  se_a, se_b   sqrt(mean(se^2)) / sqrt(mean(image^2)), its own relative noise\n"
    "\n"
    "Prints key=value lines (relrmse first). Values that are undefined or infinite\n"
    "(e.g. relrmse of a non-black A against a black B) print as inf or nan, and as\n"
    "null with --json.\n"
    "\n"
    "options:\n"
    "  --json           print one JSON object with the same keys instead\n"
    "  --mask-below V   ignore pixels whose reference luminance\n"
    "                   (0.2126 R + 0.7152 G + 0.0722 B) is below V\n";

static const vdbs_arg_option options[] = {
    {"--json", VDBS_ARG_FLAG},
    {"--mask-below", VDBS_ARG_VALUE},
    {NULL, VDBS_ARG_FLAG},
};

typedef struct metric {
    const char *key;
    double value;
    int shown;
    int integer; /* printed without exponent however large */
} metric;

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .run = run,
    .name = "compare",
    .options = options,
    .help = help,
    .min_positional = 2,
    .max_positional = 2,
    .positional_error = "expected two images: A and the reference B",
};

static int run(const vdbs_options_args *args)
{
    vdbs_error err;
    vdbs_status st;
    double mask_below = 0.0;
    const char *v = vdbs_options_value(args, "--mask-below");
    if (v && (st = vdbs_options_number("--mask-below", v, &mask_below, &err)) != VDBS_OK)
        return vdbs_command_fail("compare", st, err.message);
    if (mask_below < 0.0)
        return vdbs_command_fail("compare", 2, "--mask-below must be >= 0");

    const char *path_a = args->positional[0], *path_b = args->positional[1];
    vdbs_image a, b;
    if ((st = vdbs_image_read(path_a, &a, &err)) != VDBS_OK)
        return vdbs_command_fail("compare", st, err.message);
    if ((st = vdbs_image_read(path_b, &b, &err)) != VDBS_OK) {
        vdbs_image_free(&a);
        return vdbs_command_fail("compare", st, err.message);
    }
    if (a.width != b.width || a.height != b.height) {
        char message[VDBS_ERROR_MAX + 64];
        snprintf(message, sizeof message, "image sizes differ: %s is %dx%d, reference %s is %dx%d",
                 path_a, a.width, a.height, path_b, b.width, b.height);
        vdbs_image_free(&a);
        vdbs_image_free(&b);
        return vdbs_command_fail("compare", 2, message);
    }
    vdbs_image_metrics m;
    st = vdbs_image_compare(&a, &b, mask_below, &m, &err);
    const int se_a = a.se != NULL, se_b = b.se != NULL;
    vdbs_image_free(&a);
    vdbs_image_free(&b);
    if (st != VDBS_OK)
        return vdbs_command_fail("compare", st, err.message);

    const metric list[] = {
        {"relrmse", m.relrmse, 1, 0},
        {"mean_rel", m.mean_rel, 1, 0},
        {"p99_rel", m.p99_rel, 1, 0},
        {"mean_ratio", m.mean_ratio, 1, 0},
        {"samples", (double)m.samples, 1, 1},
        {"noise_share", m.noise_share, m.has_se, 0},
        {"z_mean", m.z_mean, m.has_se, 0},
        {"z_rms", m.z_rms, m.has_se, 0},
        {"z_samples", (double)m.z_samples, m.has_se, 1},
        {"se_a", m.se_image_a, se_a, 0},
        {"se_b", m.se_image_b, se_b, 0},
    };
    const size_t count = sizeof list / sizeof list[0];
    if (vdbs_options_flag(args, "--json")) {
        cJSON *j = cJSON_CreateObject();
        for (size_t i = 0; i < count; ++i) {
            if (!list[i].shown)
                continue;
            /* JSON has no inf or nan. */
            if (isfinite(list[i].value))
                cJSON_AddNumberToObject(j, list[i].key, list[i].value);
            else
                cJSON_AddNullToObject(j, list[i].key);
        }
        char *text = cJSON_Print(j);
        cJSON_Delete(j);
        if (!text)
            return vdbs_command_fail("compare", 1, "out of memory printing JSON");
        vdbs_command_out("%s\n", text);
        free(text);
    } else {
        for (size_t i = 0; i < count; ++i) {
            if (!list[i].shown)
                continue;
            vdbs_command_out(list[i].integer ? "%s=%.0f\n" : "%s=%.9g\n", list[i].key,
                             list[i].value);
        }
    }
    return VDBS_EXIT_OK;
}

const vdbs_command_spec *vdbs_command_compare(void)
{
    return &command;
}
