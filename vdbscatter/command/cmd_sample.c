/* vdbscatter sample NAME -o OUT.vdb: procedural sample volumes. */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "options.h"
#include "vdbscatter/envmap.h"
#include "vdbscatter/samples.h"
#include "vdbscatter/vdbio.h"

static const char help[] =
    "usage: vdbscatter sample NAME -o OUT.vdb [--res N] [--seed S] [--time T] [-q]\n"
    "       vdbscatter sample sky -o SKY.exr [--res N]\n"
    "\n"
    "Writes a procedural density volume in [-1,1]^3 (voxel size 2/N, centred on the\n"
    "origin), or the test environment map. NAME is one of:\n"
    "  cloud   fBm-noise cumulus (sparse, soft edges)\n"
    "  smoke   a rising plume\n"
    "  sphere  homogeneous ball of radius 0.8, density 1\n"
    "  slab    homogeneous slab |y| <= 0.25 (lit face +Y), density 1\n"
    "  cube    homogeneous cube of half-size 0.6, density 1\n"
    "  sky     a lat-long OpenEXR sky of 2N x N texels: blue sky, dim ground and a\n"
    "          small bright sun (longitude 30, latitude 35 degrees)\n"
    "\n"
    "options:\n"
    "  -o, --output FILE  output VDB (required)\n"
    "  --res N            voxels per axis (default 64, 1..1024)\n"
    "  --seed S           noise seed for cloud and smoke (default 1)\n"
    "  --time T           smoke at time T in [0, 1]: the plume rising, its head\n"
    "                     climbing from 30% of the full height (T 0) to all of it\n"
    "                     (T 1), so that frames T = f / F make a sequence whose box\n"
    "                     grows (without --time: the still plume)\n"
    "  -q                 no warnings\n";

static const vdbs_arg_option options[] = {
    {"-o", VDBS_ARG_VALUE},     {"--output", VDBS_ARG_VALUE}, {"--res", VDBS_ARG_VALUE},
    {"--seed", VDBS_ARG_VALUE}, {"--time", VDBS_ARG_VALUE},   {"-q", VDBS_ARG_FLAG},
    {NULL, VDBS_ARG_FLAG},
};

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .run = run,
    .name = "sample",
    .options = options,
    .help = help,
    .min_positional = 1,
    .max_positional = 1,
    .positional_error = "expected one sample NAME (cloud, smoke, sphere, slab, cube, sky)",
};

static int run(const vdbs_options_args *args)
{
    vdbs_error err;
    const char *out = vdbs_options_output(args);
    if (!out)
        return vdbs_command_fail("sample", 2, "missing -o OUT.vdb");
    long res = 64, seed = 1;
    const char *v;
    if ((v = vdbs_options_value(args, "--res")) &&
        vdbs_options_integer("--res", v, 1, 1024, &res, &err) != VDBS_OK)
        return vdbs_command_fail("sample", 2, err.message);
    if ((v = vdbs_options_value(args, "--seed")) &&
        vdbs_options_integer("--seed", v, 0, 4294967295L, &seed, &err) != VDBS_OK)
        return vdbs_command_fail("sample", 2, err.message);
    double time = -1.0;
    if ((v = vdbs_options_value(args, "--time"))) {
        if (vdbs_options_number("--time", v, &time, &err) != VDBS_OK)
            return vdbs_command_fail("sample", 2, err.message);
        if (!(time >= 0.0 && time <= 1.0))
            return vdbs_command_fail("sample", 2, "--time: expected a time in [0, 1]");
        if (strcmp(args->positional[0], "smoke") != 0)
            return vdbs_command_fail("sample", 2, "--time: only smoke moves");
    }
    int quiet = vdbs_options_flag(args, "-q");

    if (strcmp(args->positional[0], "sky") == 0) {
        vdbs_image image;
        vdbs_status st = vdbs_envmap_test_sky((int)res, &image, &err);
        if (st == VDBS_OK)
            st = vdbs_image_write(out, &image, 0.0, &err);
        vdbs_image_free(&image);
        return st == VDBS_OK ? VDBS_EXIT_OK : vdbs_command_fail("sample", st, err.message);
    }
    vdbio_density *density = NULL;
    vdbs_status st =
        vdbs_sample_create_at(args->positional[0], (int)res, (uint32_t)seed, time, &density, &err);
    if (st != VDBS_OK)
        return vdbs_command_fail("sample", st, err.message);
    char res_text[16], seed_text[16], time_text[32];
    snprintf(res_text, sizeof res_text, "%ld", res);
    snprintf(seed_text, sizeof seed_text, "%ld", seed);
    snprintf(time_text, sizeof time_text, "%.17g", time);
    vdbio_meta meta[] = {
        {"vdbscatter_sample", args->positional[0]},
        {"vdbscatter_sample_res", res_text},
        {"vdbscatter_sample_seed", seed_text},
        {"vdbscatter_sample_time", time_text},
    };
    vdbio_write_request request = {0};
    request.density = density;
    request.file_meta = meta;
    request.file_meta_count = time >= 0.0 ? 4 : 3;
    request.warn = vdbs_command_warn;
    request.warn_user = &quiet;
    st = vdbio_write(out, NULL, &request, &err);
    vdbio_density_free(density);
    if (st != VDBS_OK)
        return vdbs_command_fail("sample", st, err.message);
    return VDBS_EXIT_OK;
}

const vdbs_command_spec *vdbs_command_sample(void)
{
    return &command;
}
