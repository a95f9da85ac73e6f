/* vdbscatter info FILE.vdb: what a VDB holds and how thick it is optically. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "commands.h"
#include "options.h"
#include "vdbscatter/advice.h"
#include "vdbscatter/gpu.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/vdbio.h"
#include "vdbscatter/volume.h"

static const char help[] =
    "usage: vdbscatter info [FILE.vdb] [--density-scale S] [--target-depth TAU]\n"
    "                       [--grid NAME[@INDEX]] [--json] [--gpu]\n"
    "\n"
    "Lists every grid of FILE (type, class, voxel size, active bounding box in index and\n"
    "world space, active voxels and tiles, value range, background) and the optical\n"
    "thickness of the density grid for the given density scale (default 1): the largest\n"
    "per-voxel depth and the depth of straight rays through the volume along each index\n"
    "axis, with their mean.\n"
    "\n"
    "options:\n"
    "  --density-scale S   sigma_t = density * S\n"
    "  --target-depth TAU  also print the density scale that gives a mean optical depth\n"
    "                      TAU through the volume (what --density-scale auto:TAU uses;\n"
    "                      clouds look like clouds at about 5-20)\n"
    "  --grid NAME[@I]     which grid the optical thickness is computed for\n"
    "  --from-levelset     treat a level set as a fog volume for the thickness\n"
    "  --gpu               report the OpenGL device found through EGL (FILE optional)\n"
    "  --json              print JSON on stdout\n";

static const vdbs_arg_option options[] = {
    {"--density-scale", VDBS_ARG_VALUE},
    {"--grid", VDBS_ARG_VALUE},
    {"--json", VDBS_ARG_FLAG},
    {"--gpu", VDBS_ARG_FLAG},
    {"--from-levelset", VDBS_ARG_FLAG},
    {"--target-depth", VDBS_ARG_VALUE},
    {NULL, VDBS_ARG_FLAG},
};

static cJSON *ints3(const int v[3])
{
    return cJSON_CreateIntArray(v, 3);
}

static cJSON *gpu_json(int *ok, char *message, size_t size)
{
    cJSON *j = cJSON_CreateObject();
    vdbs_gpu *gpu = NULL;
    vdbs_error err;
    *ok = vdbs_gpu_create(&gpu, &err) == VDBS_OK;
    cJSON_AddBoolToObject(j, "available", *ok);
    cJSON_AddBoolToObject(j, "hardware_device", vdbs_gpu_hardware_available());
    if (!*ok) {
        cJSON_AddStringToObject(j, "error", err.message);
        snprintf(message, size, "%s", err.message);
        return j;
    }
    const vdbs_gpu_info *info = vdbs_gpu_get_info(gpu);
    cJSON_AddStringToObject(j, "platform", info->platform);
    cJSON_AddStringToObject(j, "vendor", info->vendor);
    cJSON_AddStringToObject(j, "renderer", info->renderer);
    cJSON_AddStringToObject(j, "version", info->version);
    cJSON_AddStringToObject(j, "glsl_version", info->glsl_version);
    cJSON_AddBoolToObject(j, "software", info->is_software);
    cJSON_AddNumberToObject(j, "max_ssbo_bytes", (double)info->max_ssbo_bytes);
    cJSON_AddNumberToObject(j, "max_work_group_invocations", info->max_work_group_invocations);
    vdbs_gpu_destroy(gpu);
    return j;
}

/* The world axis-aligned bounds of a grid's active voxels (their faces, half a voxel
 * beyond the centres of the index box). */
static void world_box(const vdbio_grid_summary *g, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = HUGE_VAL;
        hi[a] = -HUGE_VAL;
    }
    for (int c = 0; c < 8; ++c) {
        double idx[3];
        for (int a = 0; a < 3; ++a)
            idx[a] = (c >> a) & 1 ? g->bbox_max[a] + 0.5 : g->bbox_min[a] - 0.5;
        for (int r = 0; r < 3; ++r) {
            const double *m = g->transform.m[r];
            double w = m[0] * idx[0] + m[1] * idx[1] + m[2] * idx[2] + m[3];
            lo[r] = fmin(lo[r], w);
            hi[r] = fmax(hi[r], w);
        }
    }
}

/* What the options ask for. */
typedef struct info_request {
    int want_gpu, json, from_levelset;
    double scale;     /* --density-scale, default 1 */
    double target;    /* --target-depth, 0 without */
    vdbs_scene scene; /* --grid */
} info_request;

static vdbs_status parse_request(const vdbs_options_args *args, info_request *r, vdbs_error *err)
{
    vdbs_status st = VDBS_OK;
    r->want_gpu = vdbs_options_flag(args, "--gpu");
    r->json = vdbs_options_flag(args, "--json");
    r->from_levelset = vdbs_options_flag(args, "--from-levelset");
    r->scale = 1.0;
    const char *v = vdbs_options_value(args, "--density-scale");
    if (v && (st = vdbs_options_number("--density-scale", v, &r->scale, err)) != VDBS_OK)
        return st;
    if (r->scale < 0.0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--density-scale must be >= 0");
    r->target = 0.0;
    if ((v = vdbs_options_value(args, "--target-depth"))) {
        if ((st = vdbs_options_number("--target-depth", v, &r->target, err)) != VDBS_OK)
            return st;
        if (!(r->target > 0.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--target-depth: expected a depth > 0");
    }
    vdbs_scene_init(&r->scene);
    if ((v = vdbs_options_value(args, "--grid")))
        st = vdbs_scene_set_grid(&r->scene, v, err);
    return st;
}

static cJSON *grid_json(const vdbio_grid_summary *g)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", g->name);
    cJSON_AddStringToObject(o, "type", g->value_type);
    cJSON_AddStringToObject(o, "class", g->grid_class);
    cJSON_AddBoolToObject(o, "affine", g->is_affine);
    cJSON_AddItemToObject(o, "voxel_size", cJSON_CreateDoubleArray(g->voxel_size, 3));
    cJSON_AddItemToObject(o, "bbox_min", ints3(g->bbox_min));
    cJSON_AddItemToObject(o, "bbox_max", ints3(g->bbox_max));
    if (g->active_voxels > 0 && g->is_affine) {
        double lo[3], hi[3];
        world_box(g, lo, hi);
        cJSON_AddItemToObject(o, "world_min", cJSON_CreateDoubleArray(lo, 3));
        cJSON_AddItemToObject(o, "world_max", cJSON_CreateDoubleArray(hi, 3));
    }
    cJSON_AddNumberToObject(o, "active_voxels", (double)g->active_voxels);
    cJSON_AddNumberToObject(o, "active_tiles", (double)g->active_tiles);
    cJSON_AddNumberToObject(o, "background", g->background);
    cJSON_AddNumberToObject(o, "value_min", g->value_min);
    cJSON_AddNumberToObject(o, "value_max", g->value_max);
    return o;
}

/* Optical thickness of the grid bake would use; a file without one still lists. */
static cJSON *thickness_json(const char *path, const info_request *r)
{
    vdbio_read_options read = {0};
    read.grid_name = r->scene.grid[0] ? r->scene.grid : NULL;
    read.grid_index = r->scene.grid_index;
    read.from_levelset = r->from_levelset;
    vdbs_volume volume;
    vdbs_error err;
    cJSON *optics = cJSON_CreateObject();
    cJSON_AddNumberToObject(optics, "density_scale", r->scale);
    if (vdbs_volume_load(path, &read, &volume, &err) != VDBS_OK) {
        cJSON_AddStringToObject(optics, "unavailable", err.message);
        return optics;
    }
    vdbs_thickness t;
    vdbs_volume_thickness(&volume, r->scale, &t);
    cJSON_AddStringToObject(optics, "grid", volume.info.name);
    cJSON_AddNumberToObject(optics, "voxel_max", t.voxel_max);
    cJSON_AddItemToObject(optics, "axis_mean", cJSON_CreateDoubleArray(t.axis_mean, 3));
    cJSON_AddItemToObject(optics, "axis_max", cJSON_CreateDoubleArray(t.axis_max, 3));
    /* Depth is linear in the scale: the scale-1 mean without a second set of rays. */
    const double mean = vdbs_thickness_mean(&t);
    const double mean1 = r->scale > 0.0 ? mean / r->scale : vdbs_volume_mean_depth(&volume);
    cJSON_AddNumberToObject(optics, "mean", mean);
    if (r->target > 0.0) {
        cJSON_AddNumberToObject(optics, "target_depth", r->target);
        if (mean1 > 0.0)
            cJSON_AddNumberToObject(optics, "density_scale_for_target", r->target / mean1);
    }
    vdbs_volume_free(&volume);
    return optics;
}

/* The file's grids and optical thickness into root. */
static vdbs_status file_json(cJSON *root, const char *path, const info_request *r, vdbs_error *err)
{
    vdbio_grid_summary *grids = NULL;
    int count = 0;
    vdbs_status st = vdbio_list_grids(path, &grids, &count, err);
    if (st != VDBS_OK)
        return st;
    cJSON_AddStringToObject(root, "file", path);
    cJSON *list = cJSON_AddArrayToObject(root, "grids");
    for (int i = 0; i < count; ++i)
        cJSON_AddItemToArray(list, grid_json(&grids[i]));
    free(grids);
    cJSON_AddItemToObject(root, "optical_thickness", thickness_json(path, r));
    return VDBS_OK;
}

static void print_gpu(const cJSON *gpu)
{
    vdbs_command_out("gpu: %s (%s, EGL platform %s, %s)\n",
                     cJSON_GetObjectItem(gpu, "renderer")->valuestring,
                     cJSON_GetObjectItem(gpu, "version")->valuestring,
                     cJSON_GetObjectItem(gpu, "platform")->valuestring,
                     cJSON_IsTrue(cJSON_GetObjectItem(gpu, "software")) ? "software" : "hardware");
}

static void print_grid(const cJSON *g)
{
    const cJSON *vs = cJSON_GetObjectItem(g, "voxel_size");
    const cJSON *lo = cJSON_GetObjectItem(g, "bbox_min");
    const cJSON *hi = cJSON_GetObjectItem(g, "bbox_max");
    vdbs_command_out(
        "  %-12s %-6s %-10s voxel %.4g x %.4g x %.4g%s\n",
        cJSON_GetObjectItem(g, "name")->valuestring, cJSON_GetObjectItem(g, "type")->valuestring,
        cJSON_GetObjectItem(g, "class")->valuestring, cJSON_GetArrayItem(vs, 0)->valuedouble,
        cJSON_GetArrayItem(vs, 1)->valuedouble, cJSON_GetArrayItem(vs, 2)->valuedouble,
        cJSON_IsTrue(cJSON_GetObjectItem(g, "affine")) ? "" : " (frustum map)");
    if (cJSON_GetObjectItem(g, "active_voxels")->valuedouble > 0)
        vdbs_command_out("               bbox [%d,%d,%d]->[%d,%d,%d]  active %.0f (tiles %.0f)  "
                         "range [%g, %g]  background %g\n",
                         cJSON_GetArrayItem(lo, 0)->valueint, cJSON_GetArrayItem(lo, 1)->valueint,
                         cJSON_GetArrayItem(lo, 2)->valueint, cJSON_GetArrayItem(hi, 0)->valueint,
                         cJSON_GetArrayItem(hi, 1)->valueint, cJSON_GetArrayItem(hi, 2)->valueint,
                         cJSON_GetObjectItem(g, "active_voxels")->valuedouble,
                         cJSON_GetObjectItem(g, "active_tiles")->valuedouble,
                         cJSON_GetObjectItem(g, "value_min")->valuedouble,
                         cJSON_GetObjectItem(g, "value_max")->valuedouble,
                         cJSON_GetObjectItem(g, "background")->valuedouble);
    else
        vdbs_command_out("               empty\n");
    const cJSON *wlo = cJSON_GetObjectItem(g, "world_min");
    const cJSON *whi = cJSON_GetObjectItem(g, "world_max");
    if (wlo && whi)
        vdbs_command_out(
            "               world bbox [%.6g,%.6g,%.6g]->[%.6g,%.6g,%.6g]\n",
            cJSON_GetArrayItem(wlo, 0)->valuedouble, cJSON_GetArrayItem(wlo, 1)->valuedouble,
            cJSON_GetArrayItem(wlo, 2)->valuedouble, cJSON_GetArrayItem(whi, 0)->valuedouble,
            cJSON_GetArrayItem(whi, 1)->valuedouble, cJSON_GetArrayItem(whi, 2)->valuedouble);
}

static void print_thickness(const cJSON *o, const info_request *r)
{
    const cJSON *na = cJSON_GetObjectItem(o, "unavailable");
    if (na) {
        vdbs_command_out("optical thickness: unavailable (%s)\n", na->valuestring);
        return;
    }
    const cJSON *mean = cJSON_GetObjectItem(o, "axis_mean");
    const cJSON *max = cJSON_GetObjectItem(o, "axis_max");
    vdbs_command_out(
        "optical thickness of '%s' at density scale %g:\n"
        "  per voxel max %.4g\n"
        "  through the volume along x/y/z: mean %.4g / %.4g / %.4g, max %.4g / "
        "%.4g / %.4g\n",
        cJSON_GetObjectItem(o, "grid")->valuestring, r->scale,
        cJSON_GetObjectItem(o, "voxel_max")->valuedouble, cJSON_GetArrayItem(mean, 0)->valuedouble,
        cJSON_GetArrayItem(mean, 1)->valuedouble, cJSON_GetArrayItem(mean, 2)->valuedouble,
        cJSON_GetArrayItem(max, 0)->valuedouble, cJSON_GetArrayItem(max, 1)->valuedouble,
        cJSON_GetArrayItem(max, 2)->valuedouble);
    vdbs_command_out("  mean through the volume %.4g\n",
                     cJSON_GetObjectItem(o, "mean")->valuedouble);
    const cJSON *fit = cJSON_GetObjectItem(o, "density_scale_for_target");
    if (fit)
        vdbs_command_out("density scale for a mean optical depth of %g: %.6g "
                         "(--density-scale auto:%g)\n",
                         r->target, fit->valuedouble, r->target);
    else if (r->target > 0.0)
        vdbs_command_out("density scale for a mean optical depth of %g: none (no density)\n",
                         r->target);
    else if (cJSON_GetObjectItem(o, "mean")->valuedouble > 0.0)
        vdbs_command_out("clouds look like clouds at a mean optical depth of about 5-20: "
                         "--density-scale auto:10 is %.6g here (--target-depth TAU for "
                         "another depth)\n",
                         10.0 * r->scale / cJSON_GetObjectItem(o, "mean")->valuedouble);
}

/* The text form of root. */
static void print_text(const cJSON *root, const info_request *r)
{
    const cJSON *gpu = cJSON_GetObjectItem(root, "gpu");
    if (gpu)
        print_gpu(gpu);
    const cJSON *list = cJSON_GetObjectItem(root, "grids");
    if (!list)
        return;
    vdbs_command_out("%s: %d grid%s\n", cJSON_GetObjectItem(root, "file")->valuestring,
                     cJSON_GetArraySize(list), cJSON_GetArraySize(list) == 1 ? "" : "s");
    const cJSON *g;
    cJSON_ArrayForEach(g, list)
    {
        print_grid(g);
    }
    print_thickness(cJSON_GetObjectItem(root, "optical_thickness"), r);
}

static int run(const vdbs_options_args *args);

static const vdbs_command_spec command = {
    .run = run,
    .name = "info",
    .options = options,
    .help = help,
    .max_positional = 1,
    .positional_error = "expected one FILE.vdb",
};

static int run(const vdbs_options_args *args)
{
    vdbs_error err;
    vdbs_status st;
    if (args->positional_count == 0 &&
        !vdbs_options_flag(args, "--gpu")) /* FILE optional with --gpu */
        return vdbs_command_fail("info", 2, command.positional_error);
    info_request r;
    if ((st = parse_request(args, &r, &err)) != VDBS_OK)
        return vdbs_command_fail("info", st, err.message);

    cJSON *root = cJSON_CreateObject();
    int status = VDBS_EXIT_OK;
    if (r.want_gpu) {
        int ok;
        char message[VDBS_ERROR_MAX];
        cJSON_AddItemToObject(root, "gpu", gpu_json(&ok, message, sizeof message));
        if (!ok && !r.json) {
            cJSON_Delete(root);
            return vdbs_command_fail("info", 1, message);
        }
        if (!ok)
            status = VDBS_EXIT_FAILURE;
    }
    if (args->positional_count == 1 &&
        (st = file_json(root, args->positional[0], &r, &err)) != VDBS_OK) {
        cJSON_Delete(root);
        return vdbs_command_fail("info", st, err.message);
    }
    if (r.json) {
        char *text = cJSON_Print(root);
        vdbs_command_out("%s\n", text);
        free(text);
    } else {
        print_text(root, &r);
    }
    cJSON_Delete(root);
    return status;
}

const vdbs_command_spec *vdbs_command_info(void)
{
    return &command;
}
