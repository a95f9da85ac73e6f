/* Scene files: parsing of the docs/design.md shape, path resolution, every error class with
 * its key path, validation ranges, and the to_json round trip. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/suggest.h"
#include "vdbscatter/solver.h"

/* The docs/design.md example, extended with every light type and every optional key. */
static const char *const sketch =
    "{ \"volume\": {\"file\": \"cloud.vdb\", \"grid\": \"density\", \"density_scale\": 20.0,\n"
    "              \"albedo\": [0.99, 0.99, 0.99], \"g\": 0.85},\n"
    "  \"lights\": [ {\"type\": \"sun\", \"direction\": [0.3, -1, 0.2], \"irradiance\": [3, 3, "
    "3], \"angular_diameter_deg\": 0},\n"
    "              {\"type\": \"point\", \"position\": [0,1,0], \"intensity\": [5,5,5]},\n"
    "              {\"type\": \"env\", \"color\": [0.2, 0.3, 0.5]},\n"
    "              {\"type\": \"env\", \"file\": \"sky.exr\", \"scale\": 1.0} ],\n"
    "  \"camera\": {\"position\": [0, 1, 6], \"target\": [0, 0, 0], \"fov_deg\": 35, \"width\": "
    "640, \"height\": 480, \"up\": [0,1,0]},\n"
    "  \"solver\": {\"method\": \"pop\", \"quality\": \"medium\"} }\n";

static vdbs_scene *new_scene(void)
{
    vdbs_scene *s = malloc(sizeof *s);
    assert_non_null(s);
    vdbs_scene_init(s);
    return s;
}

static void assert_vec3(const double v[3], double x, double y, double z)
{
    assert_true(v[0] == x && v[1] == y && v[2] == z);
}

static void assert_contains(const char *haystack, const char *needle)
{
    if (!strstr(haystack, needle))
        fail_msg("message \"%s\" does not contain \"%s\"", haystack, needle);
}

static void test_design_sketch(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    assert_int_equal(vdbs_scene_parse(sketch, "/data/scenes", s, &err), VDBS_OK);

    assert_string_equal(s->volume_file, "/data/scenes/cloud.vdb");
    assert_string_equal(s->grid, "density");
    assert_int_equal(s->grid_index, 0);
    assert_true(s->density_scale == 20.0);
    assert_vec3(s->albedo, 0.99, 0.99, 0.99);
    assert_true(s->g == 0.85);

    assert_int_equal(s->light_count, 4);
    assert_int_equal(s->lights[0].type, VDBS_LIGHT_SUN);
    assert_vec3(s->lights[0].direction, 0.3, -1.0, 0.2);
    assert_vec3(s->lights[0].color, 3.0, 3.0, 3.0);
    assert_true(s->lights[0].angular_diameter_deg == 0.0);
    assert_int_equal(s->lights[1].type, VDBS_LIGHT_POINT);
    assert_vec3(s->lights[1].position, 0.0, 1.0, 0.0);
    assert_vec3(s->lights[1].color, 5.0, 5.0, 5.0);
    assert_int_equal(s->lights[2].type, VDBS_LIGHT_ENV);
    assert_string_equal(vdbs_light_env_file(s, &s->lights[2]), "");
    assert_vec3(s->lights[2].color, 0.2, 0.3, 0.5);
    assert_int_equal(s->lights[3].type, VDBS_LIGHT_ENV);
    assert_string_equal(vdbs_light_env_file(s, &s->lights[3]), "/data/scenes/sky.exr");
    assert_true(s->lights[3].env_scale == 1.0);

    assert_int_equal(s->camera.present, 1);
    assert_vec3(s->camera.position, 0.0, 1.0, 6.0);
    assert_vec3(s->camera.target, 0.0, 0.0, 0.0);
    assert_vec3(s->camera.up, 0.0, 1.0, 0.0);
    assert_true(s->camera.fov_deg == 35.0);
    assert_int_equal(s->camera.width, 640);
    assert_int_equal(s->camera.height, 480);
    assert_string_equal(s->method, "pop");
    assert_string_equal(s->quality, "medium");

    /* validate normalises the sun direction in place and changes nothing else */
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);
    const double *d = s->lights[0].direction;
    double len = sqrt(0.3 * 0.3 + 1.0 + 0.2 * 0.2);
    assert_true(fabs(d[0] - 0.3 / len) < 1e-15);
    assert_true(fabs(d[1] + 1.0 / len) < 1e-15);
    assert_true(fabs(d[2] - 0.2 / len) < 1e-15);
    assert_true(fabs(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1.0) < 1e-15);
    assert_vec3(s->lights[1].position, 0.0, 1.0, 0.0);
    free(s);
}

static void test_defaults_and_scalars(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    assert_int_equal(vdbs_scene_parse("{}", NULL, s, &err), VDBS_OK);
    /* Cycles' Principled Volume defaults */
    assert_true(s->density_scale == 1.0);
    assert_vec3(s->albedo, 0.5, 0.5, 0.5);
    assert_true(s->g == 0.0);
    /* The measured best error for the time on general volumes. */
    assert_string_equal(s->method, "svd");
    assert_string_equal(s->quality, "low");
    assert_true(s->density_target_depth == 0.0);
    assert_string_equal(s->volume_file, "");
    assert_string_equal(s->grid, "");
    assert_int_equal(s->light_count, 0);
    assert_int_equal(s->camera.present, 0);

    /* a single number stands for all three components of albedo and colours */
    assert_int_equal(
        vdbs_scene_parse("{\"volume\": {\"albedo\": 0.7}, \"lights\": [{\"type\": \"sun\", "
                         "\"direction\": [0,-1,0], \"irradiance\": 2}, {\"type\": \"env\", "
                         "\"color\": 0.25}, {\"type\": \"point\", \"position\": [1,2,3]}]}",
                         NULL, s, &err),
        VDBS_OK);
    assert_vec3(s->albedo, 0.7, 0.7, 0.7);
    assert_vec3(s->lights[0].color, 2.0, 2.0, 2.0);
    assert_vec3(s->lights[1].color, 0.25, 0.25, 0.25);
    assert_vec3(s->lights[2].color, 1.0, 1.0, 1.0); /* default intensity */

    /* a camera needs only position and target */
    assert_int_equal(vdbs_scene_parse("{\"camera\": {\"position\": [0,0,5], \"target\": [0,0,0]}}",
                                      NULL, s, &err),
                     VDBS_OK);
    assert_int_equal(s->camera.present, 1);
    assert_vec3(s->camera.up, 0.0, 1.0, 0.0);
    assert_true(s->camera.fov_deg > 0.0 && s->camera.width > 0 && s->camera.height > 0);
    free(s);
}

static void test_relative_paths(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    const char *json = "{\"volume\": {\"file\": \"vols/cloud.vdb\"}, \"lights\": [{\"type\": "
                       "\"env\", \"file\": \"sky.exr\", \"scale\": 2}]}";
    assert_int_equal(vdbs_scene_parse(json, "scenes", s, &err), VDBS_OK);
    assert_string_equal(s->volume_file, "scenes/vols/cloud.vdb");
    assert_string_equal(vdbs_light_env_file(s, &s->lights[0]), "scenes/sky.exr");
    assert_true(s->lights[0].env_scale == 2.0);
    assert_int_equal(vdbs_scene_parse(json, "/a/b/", s, &err), VDBS_OK);
    assert_string_equal(s->volume_file, "/a/b/vols/cloud.vdb");
    assert_int_equal(vdbs_scene_parse(json, NULL, s, &err), VDBS_OK);
    assert_string_equal(s->volume_file, "vols/cloud.vdb");
    assert_int_equal(vdbs_scene_parse(json, "", s, &err), VDBS_OK);
    assert_string_equal(s->volume_file, "vols/cloud.vdb");
    /* absolute paths are kept */
    assert_int_equal(
        vdbs_scene_parse("{\"volume\": {\"file\": \"/abs/cloud.vdb\"}}", "scenes", s, &err),
        VDBS_OK);
    assert_string_equal(s->volume_file, "/abs/cloud.vdb");
    free(s);
}

static void test_load(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    char expected[4096];
    const char *path = test_tmp_path("test_scene_load.json");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(sketch, f);
    fclose(f);
    assert_int_equal(vdbs_scene_load(path, s, &err), VDBS_OK);
    snprintf(expected, sizeof expected, "%s", test_tmp_path("cloud.vdb"));
    assert_string_equal(s->volume_file, expected);
    assert_int_equal(s->light_count, 4);

    /* errors in a file name the file */
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("{\"volume\": {\"g\": true}}", f);
    fclose(f);
    assert_int_equal(vdbs_scene_load(path, s, &err), VDBS_ERR_INPUT);
    snprintf(expected, sizeof expected, "scene %s: volume.g: ", path);
    assert_contains(err.message, expected);

    const char *missing = test_tmp_path("no_such_scene.json");
    assert_int_equal(vdbs_scene_load(missing, s, &err), VDBS_ERR_INPUT);
    snprintf(expected, sizeof expected, "scene %s: ", missing);
    assert_contains(err.message, expected);

    /* a directory opens but cannot be read */
    assert_int_equal(vdbs_scene_load(test_tmp_path(""), s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "scene ");
    free(s);
}

typedef struct error_case {
    const char *json;
    const char *message; /* expected part of the message */
} error_case;

static const char *const sun = "{\"type\": \"sun\", \"direction\": [0,-1,0]}";
#define SPHERE "{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 1}"

static void test_parse_errors(void **state)
{
    (void)state;
    char irradance[512];
    snprintf(irradance, sizeof irradance,
             "{\"lights\": [%s, {\"type\": \"sun\", \"direction\": [0,-1,0], \"irradance\": "
             "[1,1,1]}]}",
             sun);
    const error_case cases[] = {
        /* unknown keys, at every level */
        {irradance, "scene: lights[1]: unknown key \"irradance\""},
        {"{\"volum\": {}}", "scene: unknown key \"volum\""},
        {"{\"volume\": {\"density\": 1}}", "scene: volume: unknown key \"density\""},
        {"{\"camera\": {\"position\": [0,0,1], \"target\": [0,0,0], \"fov\": 30}}",
         "scene: camera: unknown key \"fov\""},
        {"{\"solver\": {\"methd\": \"pop\"}}", "scene: solver: unknown key \"methd\""},
        {"{\"lights\": [{\"type\": \"sun\", \"direction\": [0,-1,0], \"position\": [0,0,0]}]}",
         "scene: lights[0]: unknown key \"position\""},
        {"{\"volume\": {\"g\": 0.1, \"g\": 0.2}}", "scene: volume: duplicate key \"g\""},
        /* keys are case-sensitive */
        {"{\"Volume\": {}}", "scene: unknown key \"Volume\""},
        /* wrong types */
        {"{\"volume\": {\"g\": \"0.5\"}}", "scene: volume.g: expected a number, got a string"},
        {"{\"volume\": {\"density_scale\": null}}", "scene: volume.density_scale: expected"},
        {"{\"volume\": {\"albedo\": [1, 1]}}", "scene: volume.albedo: expected"},
        {"{\"volume\": {\"albedo\": [1, \"a\", 1]}}", "scene: volume.albedo[1]: expected"},
        {"{\"volume\": {\"file\": 3}}", "scene: volume.file: expected a string"},
        {"{\"volume\": {\"file\": \"\"}}", "scene: volume.file: expected a non-empty string"},
        {"{\"volume\": []}", "scene: volume: expected an object"},
        {"{\"lights\": {}}", "scene: lights: expected an array"},
        {"{\"lights\": [1]}", "scene: lights[0]: expected an object"},
        {"{\"lights\": [{\"type\": \"spot\"}]}", "scene: lights[0].type: unknown light type"},
        {"{\"lights\": [{\"type\": 1}]}", "scene: lights[0].type: expected a string"},
        {"{\"lights\": [{\"direction\": [0,1,0]}]}", "scene: lights[0]: missing \"type\""},
        {"{\"lights\": [{\"type\": \"sun\"}]}", "scene: lights[0]: missing \"direction\""},
        {"{\"lights\": [{\"type\": \"point\"}]}", "scene: lights[0]: missing \"position\""},
        {"{\"lights\": [{\"type\": \"sun\", \"direction\": 1}]}",
         "scene: lights[0].direction: expected an array of 3 numbers"},
        {"{\"lights\": [{\"type\": \"env\"}]}", "scene: lights[0]: an env light needs"},
        {"{\"lights\": [{\"type\": \"env\", \"file\": \"a.exr\", \"color\": 1}]}",
         "scene: lights[0]: give either \"file\" or \"color\""},
        {"{\"lights\": [{\"type\": \"env\", \"color\": 1, \"scale\": 2}]}",
         "scene: lights[0]: \"scale\" applies"},
        {"{\"camera\": {\"position\": [0,0,1], \"target\": [0,0,0], \"width\": 10.5}}",
         "scene: camera.width: expected an integer"},
        {"{\"camera\": {\"target\": [0,0,0]}}", "scene: camera: missing \"position\""},
        {"{\"solver\": {\"quality\": \"extreme\"}}", "scene: solver.quality: unknown quality"},
        {"{\"solver\": {\"method\": \"magic\"}}", "scene: solver.method: unknown method"},
        {"{\"solver\": {\"method\": 1}}", "scene: solver.method: expected a string"},
        {"{\"solver\": {\"sky_directions\": 0}}",
         "scene: solver.sky_directions: must be in 1..65536, got 0"},
        {"{\"solver\": {\"pop_res\": 1}}", "scene: solver.pop_res: must be in 2..512, got 1"},
        {"{\"solver\": {\"pop_res\": 513}}", "scene: solver.pop_res: must be in 2..512"},
        {"{\"solver\": {\"pop_res\": 3.5}}", "scene: solver.pop_res: expected an integer"},
        {"{\"solver\": {\"pop_res\": \"3\"}}", "scene: solver.pop_res: expected a number"},
        {"{\"solver\": {\"pop_ordinates\": -4}}",
         "scene: solver.pop_ordinates: must be in 1..65536, got -4"},
        {"{\"solver\": {\"pop_iterations\": 0}}",
         "scene: solver.pop_iterations: must be in 1..100000, got 0"},
        {"{\"solver\": {\"pop_decay\": \"linear\"}}",
         "scene: solver.pop_decay: unknown decay \"linear\""},
        {"{\"solver\": {\"pop_decay\": 2}}", "scene: solver.pop_decay: expected a string"},
        {"{\"solver\": {\"fld_res\": 1}}", "scene: solver.fld_res: must be in 2..1024, got 1"},
        {"{\"solver\": {\"fld_limiter\": true}}", "scene: solver.fld_limiter: expected a string"},
        {"{\"solver\": {\"fld_limiter\": \"auto\"}}",
         "scene: solver.fld_limiter: unknown limiter \"auto\""},
        {"{\"solver\": {\"fld_p1\": \"yes\"}}", "scene: solver.fld_p1: unknown value \"yes\""},
        {"{\"solver\": {\"pop_radial\": 9}}", "scene: solver.pop_radial: 9 is odd"},
        {"{\"solver\": {\"svd_directions\": 1}}",
         "scene: solver.svd_directions: must be in 2..16384, got 1"},
        {"{\"solver\": {\"svd_terms\": 0}}", "scene: solver.svd_terms: must be in 1..16384, got 0"},
        {"{\"solver\": {\"svd_res\": 513}}", "scene: solver.svd_res: must be in 2..512, got 513"},
        {"{\"solver\": {\"svd_iterations\": 0}}",
         "scene: solver.svd_iterations: must be in 1..100000, got 0"},
        {"{\"solver\": {\"svd_residual\": \"small\"}}",
         "scene: solver.svd_residual: expected a number"},
        {"{\"solver\": {\"pop_importance\": \"yes\"}}",
         "scene: solver.pop_importance: unknown value \"yes\""},
        {"{\"solver\": {\"pop_tally\": \"voxel\"}}",
         "scene: solver.pop_tally: unknown tally \"voxel\""},
        {"{\"solver\": {\"pop_re\": 3}}", "scene: solver: unknown key \"pop_re\""},
        /* non-finite numbers: JSON has no NaN, but a huge exponent overflows to Inf */
        {"{\"volume\": {\"density_scale\": 1e999}}",
         "scene: volume.density_scale: expected a finite number"},
        {"{\"volume\": {\"g\": -1e999}}", "scene: volume.g: expected a finite number"},
        {"{\"lights\": [{\"type\": \"point\", \"position\": [0, -1e999, 0]}]}",
         "scene: lights[0].position[1]: expected a finite number"},
        {"{\"volume\": {\"albedo\": 1e999}}", "scene: volume.albedo: expected a finite number"},
        /* grid specs */
        {"{\"volume\": {\"grid\": \"density@x\"}}", "scene: volume.grid: \"density@x\""},
        {"{\"volume\": {\"grid\": \"density@\"}}", "scene: volume.grid:"},
        /* syntax and shape */
        {"{\"volume\": }", "scene: invalid JSON at line 1, column 12"},
        {"{\n\"volume\": {}\n,}", "scene: invalid JSON at line 3"},
        {"{} trailing", "scene: invalid JSON"},
        {"", "scene: invalid JSON"},
        {"[]", "scene: expected a JSON object at the top level"},
        /* occluders: keys, types, presence */
        {"{\"occluders\": {}}", "scene: occluders: expected an array, got an object"},
        {"{\"occluders\": [1]}", "scene: occluders[0]: expected an object"},
        {"{\"occluders\": [{\"center\": [0,0,0]}]}", "scene: occluders[0]: missing \"type\""},
        {"{\"occluders\": [{\"type\": \"cone\"}]}",
         "scene: occluders[0].type: unknown occluder type \"cone\""},
        {"{\"occluders\": [{\"type\": 2}]}", "scene: occluders[0].type: expected a string"},
        {"{\"occluders\": [" SPHERE ", {\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 1, \"colour\": 1}]}",
         "scene: occluders[1]: unknown key \"colour\""},
        {"{\"occluders\": [{\"type\": \"box\", \"min\": [0,0,0], \"max\": [1,1,1], "
         "\"radius\": 1}]}",
         "scene: occluders[0]: unknown key \"radius\" (a box takes"},
        {"{\"occluders\": [{\"type\": \"obj\", \"file\": \"a.obj\", \"rotate\": [0,0,0]}]}",
         "scene: occluders[0]: unknown key \"rotate\""},
        {"{\"occluders\": [{\"type\": \"obj\"}]}", "scene: occluders[0]: missing \"file\""},
        {"{\"occluders\": [{\"type\": \"obj\", \"file\": \"\"}]}",
         "scene: occluders[0].file: expected a non-empty string"},
        {"{\"occluders\": [{\"type\": \"sphere\", \"center\": [0,0,0]}]}",
         "scene: occluders[0]: missing \"radius\""},
        {"{\"occluders\": [{\"type\": \"box\", \"max\": [1,1,1]}]}",
         "scene: occluders[0]: missing \"min\""},
        {"{\"occluders\": [{\"type\": \"plane\", \"point\": [0,0,0]}]}",
         "scene: occluders[0]: missing \"normal\""},
        {"{\"occluders\": [{\"type\": \"obj\", \"file\": \"a.obj\", \"scale\": [1, 2]}]}",
         "scene: occluders[0].scale: expected a number or an array of 3 numbers"},
        {"{\"occluders\": [{\"type\": \"obj\", \"file\": \"a.obj\", \"translate\": 1}]}",
         "scene: occluders[0].translate: expected an array of 3 numbers"},
        {"{\"occluders\": [{\"type\": \"sphere\", \"center\": [0,1e999,0], \"radius\": 1}]}",
         "scene: occluders[0].center[1]: expected a finite number"},
        {"{\"occluders\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": \"1\"}]}",
         "scene: occluders[0].radius: expected a number"},
        {"{\"occluders\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 1, "
         "\"radius\": 2}]}",
         "scene: occluders[0]: duplicate key \"radius\""},
        /* occluders: ranges, checked at parse too */
        {"{\"occluders\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 0}]}",
         "scene: occluders[0].radius: must be finite and > 0, got 0"},
        {"{\"occluders\": [{\"type\": \"box\", \"min\": [0,0,0], \"max\": [1,0,1]}]}",
         "scene: occluders[0].max: must exceed min on every axis"},
        {"{\"occluders\": [{\"type\": \"plane\", \"point\": [0,0,0], \"normal\": [0,0,0]}]}",
         "scene: occluders[0].normal: must be a non-zero vector"},
        {"{\"occluders\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 1, "
         "\"albedo\": 1.5}]}",
         "scene: occluders[0].albedo: each component must be in [0, 1]"},
        {"{\"occluders\": [{\"type\": \"box\", \"min\": [0,0,0], \"max\": [1,1,1], "
         "\"albedo\": [0.5, -0.1, 0.5]}]}",
         "scene: occluders[0].albedo:"},
        {"{\"occluders\": [{\"type\": \"obj\", \"file\": \"a.obj\", \"scale\": 0}]}",
         "scene: occluders[0].scale: each component must be finite and > 0"},
        {"{\"occluders\": [{\"type\": \"obj\", \"file\": \"a.obj\", \"scale\": [1, -1, 1]}]}",
         "scene: occluders[0].scale:"},
        /* fog */
        {"{\"fog\": 0.1}", "scene: fog: expected an object, got a number"},
        {"{\"fog\": {\"albedo\": 1}}", "scene: fog: missing \"sigma_t\""},
        {"{\"fog\": {\"sigma_t\": 0.1, \"density\": 1}}", "scene: fog: unknown key \"density\""},
        {"{\"fog\": {\"sigma_t\": \"thick\"}}", "scene: fog.sigma_t: expected a number"},
        {"{\"fog\": {\"sigma_t\": -0.1}}", "scene: fog.sigma_t: must be finite and >= 0"},
        {"{\"fog\": {\"sigma_t\": 0.1, \"g\": 1}}", "scene: fog.g: must be in [-0.999, 0.999]"},
        {"{\"fog\": {\"sigma_t\": 0.1, \"albedo\": 1.01}}", "scene: fog.albedo:"},
        {"{\"fog\": {\"sigma_t\": 0.1, \"box\": [0,0,0]}}", "scene: fog.box: expected an object"},
        {"{\"fog\": {\"sigma_t\": 0.1, \"box\": {\"min\": [0,0,0]}}}",
         "scene: fog.box: missing \"max\""},
        {"{\"fog\": {\"sigma_t\": 0.1, \"box\": {\"min\": [0,0,0], \"max\": [1,1,1], "
         "\"centre\": 0}}}",
         "scene: fog.box: unknown key \"centre\""},
        {"{\"fog\": {\"sigma_t\": 0.1, \"box\": {\"min\": [0,0,0], \"max\": [1,1,-1]}}}",
         "scene: fog.box.max: must exceed min on every axis"},
        {"{\"fog\": {\"sigma_t\": 0.1, \"box\": {\"min\": [0,\"a\",0], \"max\": [1,1,1]}}}",
         "scene: fog.box.min[1]: expected a number"},
    };
    vdbs_scene *s = new_scene();
    vdbs_scene *before = new_scene();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        vdbs_error err = {{0}};
        vdbs_status st = vdbs_scene_parse(cases[i].json, NULL, s, &err);
        if (st != VDBS_ERR_INPUT)
            fail_msg("case %zu (%s): status %d, expected VDBS_ERR_INPUT", i, cases[i].json,
                     (int)st);
        assert_contains(err.message, cases[i].message);
        assert_true(strncmp(err.message, "scene: ", 7) == 0);
        /* a failed parse leaves the scene untouched */
        assert_memory_equal(s, before, sizeof *s);
    }
    free(s);
    free(before);
}

static void test_validate_errors(void **state)
{
    (void)state;
    const error_case cases[] = {
        {"{}", "scene: lights: no light at all"},
        {"{\"lights\": []}", "scene: lights: no light at all"},
        {"{\"volume\": {\"g\": 0.9995}, \"lights\": [SUN]}", "scene: volume.g:"},
        {"{\"volume\": {\"g\": -1}, \"lights\": [SUN]}", "scene: volume.g:"},
        {"{\"volume\": {\"albedo\": 2}, \"lights\": [SUN]}", "scene: volume.albedo:"},
        {"{\"volume\": {\"albedo\": [0.5, -0.1, 0.5]}, \"lights\": [SUN]}",
         "scene: volume.albedo:"},
        {"{\"volume\": {\"density_scale\": -1}, \"lights\": [SUN]}",
         "scene: volume.density_scale:"},
        {"{\"lights\": [{\"type\": \"sun\", \"direction\": [0, 0, 0]}]}",
         "scene: lights[0].direction: must be a non-zero vector"},
        {"{\"lights\": [SUN, {\"type\": \"sun\", \"direction\": [0, 1, 0], \"irradiance\": [1, "
         "-1, 1]}]}",
         "scene: lights[1].irradiance:"},
        {"{\"lights\": [{\"type\": \"point\", \"position\": [0,0,0], \"intensity\": -2}]}",
         "scene: lights[0].intensity:"},
        {"{\"lights\": [{\"type\": \"env\", \"color\": [0, 0, -0.5]}]}", "scene: lights[0].color:"},
        {"{\"lights\": [{\"type\": \"env\", \"file\": \"a.exr\", \"scale\": -1}]}",
         "scene: lights[0].scale:"},
        {"{\"lights\": [{\"type\": \"sun\", \"direction\": [0, -1, 0], \"angular_diameter_deg\": "
         "-1}]}",
         "scene: lights[0].angular_diameter_deg:"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [0,0,5], \"target\": [0,0,0], "
         "\"fov_deg\": 0}}",
         "scene: camera.fov_deg:"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [0,0,5], \"target\": [0,0,0], "
         "\"fov_deg\": 180}}",
         "scene: camera.fov_deg:"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [0,0,5], \"target\": [0,0,0], "
         "\"width\": 0}}",
         "scene: camera.width:"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [0,0,5], \"target\": [0,0,0], "
         "\"height\": 16385}}",
         "scene: camera.height:"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [1,2,3], \"target\": [1,2,3]}}",
         "scene: camera.target: must differ from camera.position"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [0,5,0], \"target\": [0,0,0]}}",
         "scene: camera.up:"},
        {"{\"lights\": [SUN], \"camera\": {\"position\": [0,0,5], \"target\": [0,0,0], \"up\": "
         "[0,0,0]}}",
         "scene: camera.up:"},
    };
    vdbs_scene *s = new_scene();
    vdbs_scene *copy = new_scene();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char json[1024];
        /* substitute a valid sun for SUN */
        const char *at = strstr(cases[i].json, "SUN");
        if (at)
            snprintf(json, sizeof json, "%.*s%s%s", (int)(at - cases[i].json), cases[i].json, sun,
                     at + 3);
        else
            snprintf(json, sizeof json, "%s", cases[i].json);
        vdbs_error err = {{0}};
        if (vdbs_scene_parse(json, NULL, s, &err) != VDBS_OK)
            fail_msg("case %zu (%s) does not parse: %s", i, json, err.message);
        memcpy(copy, s, sizeof *s);
        vdbs_status st = vdbs_scene_validate(s, &err);
        if (st != VDBS_ERR_INPUT)
            fail_msg("case %zu (%s): status %d, expected VDBS_ERR_INPUT", i, json, (int)st);
        assert_contains(err.message, cases[i].message);
        /* a failed validation does not normalise anything */
        assert_memory_equal(s, copy, sizeof *s);
    }

    /* the edges of the ranges are valid */
    vdbs_error err = {{0}};
    char json[512];
    snprintf(json, sizeof json,
             "{\"volume\": {\"g\": -0.999, \"albedo\": [0, 1, 0.5], \"density_scale\": 0}, "
             "\"lights\": [%s], \"camera\": {\"position\": [0,0,5], \"target\": [0,0,0], "
             "\"fov_deg\": 179.9, \"width\": 1, \"height\": 16384}}",
             sun);
    assert_int_equal(vdbs_scene_parse(json, NULL, s, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);
    s->g = 0.999;
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);

    /* values set by code rather than JSON are checked too */
    s->density_scale = NAN;
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "volume.density_scale");
    s->density_scale = 1.0;
    s->g = NAN;
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "volume.g");
    s->g = 0.0;
    /* stored without the setters' checks, as a program may */
    assert_int_equal(vdbs_scene_solver_store(s, "svd_residual", 1.0, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "solver.svd_residual");
    assert_int_equal(vdbs_scene_solver_store(s, "svd_residual", 0.0, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_solver_store(s, "svd_directions", 16, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_solver_store(s, "svd_terms", 17, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "solver.svd_terms");
    assert_int_equal(vdbs_scene_solver_store(s, "pop_radial", 9, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "solver.pop_radial: 9 is odd");
    assert_int_equal(vdbs_scene_solver_store(s, "pop_radial", 0, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_solver_store(s, "no_such_option", 1, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "solver.no_such_option: no solver has this option");
    s->solver_setting_count--;
    assert_int_equal(vdbs_scene_solver_store(s, "svd_terms", 16, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);
    snprintf(s->method, sizeof s->method, "%s", "bogus");
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "solver.method");
    free(s);
    free(copy);
}

static void assert_scene_equal(const vdbs_scene *a, const vdbs_scene *b)
{
    assert_string_equal(a->volume_file, b->volume_file);
    assert_string_equal(a->grid, b->grid);
    assert_int_equal(a->grid_index, b->grid_index);
    assert_true(a->density_scale == b->density_scale);
    for (int c = 0; c < 3; ++c)
        assert_true(a->albedo[c] == b->albedo[c]);
    assert_true(a->g == b->g);
    assert_int_equal(a->light_count, b->light_count);
    for (int i = 0; i < a->light_count; ++i) {
        const vdbs_light *la = &a->lights[i], *lb = &b->lights[i];
        assert_int_equal(la->type, lb->type);
        for (int c = 0; c < 3; ++c) {
            assert_true(la->direction[c] == lb->direction[c]);
            assert_true(la->position[c] == lb->position[c]);
            assert_true(la->color[c] == lb->color[c]);
        }
        assert_true(la->angular_diameter_deg == lb->angular_diameter_deg);
        assert_string_equal(vdbs_light_env_file(a, la), vdbs_light_env_file(b, lb));
        assert_true(la->env_scale == lb->env_scale);
    }
    assert_int_equal(a->camera.present, b->camera.present);
    if (!a->camera.present)
        return; /* an absent camera's fields mean nothing and are not written */
    for (int c = 0; c < 3; ++c) {
        assert_true(a->camera.position[c] == b->camera.position[c]);
        assert_true(a->camera.target[c] == b->camera.target[c]);
        assert_true(a->camera.up[c] == b->camera.up[c]);
    }
    assert_true(a->camera.fov_deg == b->camera.fov_deg);
    assert_int_equal(a->camera.width, b->camera.width);
    assert_int_equal(a->camera.height, b->camera.height);
    assert_string_equal(a->method, b->method);
    assert_string_equal(a->quality, b->quality);
    assert_int_equal(a->sky_directions, b->sky_directions);
    const vdbs_solver *solver;
    for (int m = 0; (solver = vdbs_solver_at(m)) != NULL; ++m)
        for (int i = 0; i < solver->option_count; ++i)
            assert_true(vdbs_scene_solver_value(a, solver->options[i].key) ==
                        vdbs_scene_solver_value(b, solver->options[i].key));
    assert_int_equal(a->occluder_count, b->occluder_count);
    for (int i = 0; i < a->occluder_count; ++i) {
        const vdbs_occluder *oa = &a->occluders[i], *ob = &b->occluders[i];
        assert_int_equal(oa->type, ob->type);
        assert_string_equal(vdbs_occluder_obj_file(a, oa), vdbs_occluder_obj_file(b, ob));
        for (int c = 0; c < 3; ++c) {
            assert_true(oa->translate[c] == ob->translate[c]);
            assert_true(oa->scale[c] == ob->scale[c]);
            assert_true(oa->rotate_deg[c] == ob->rotate_deg[c]);
            assert_true(oa->center[c] == ob->center[c]);
            assert_true(oa->min[c] == ob->min[c]);
            assert_true(oa->max[c] == ob->max[c]);
            assert_true(oa->point[c] == ob->point[c]);
            assert_true(oa->normal[c] == ob->normal[c]);
            assert_true(oa->albedo[c] == ob->albedo[c]);
        }
        assert_true(oa->radius == ob->radius);
    }
    assert_int_equal(a->fog.present, b->fog.present);
    if (!a->fog.present)
        return;
    assert_true(a->fog.sigma_t == b->fog.sigma_t);
    assert_int_equal(a->fog.has_box, b->fog.has_box);
    for (int c = 0; c < 3; ++c) {
        assert_true(a->fog.albedo[c] == b->fog.albedo[c]);
        if (a->fog.has_box) {
            assert_true(a->fog.box_min[c] == b->fog.box_min[c]);
            assert_true(a->fog.box_max[c] == b->fog.box_max[c]);
        }
    }
}

static void round_trip(const vdbs_scene *s)
{
    vdbs_scene *back = new_scene();
    vdbs_error err = {{0}};
    char *json = vdbs_scene_to_json(s);
    assert_non_null(json);
    /* to_json holds resolved paths: read it back without a base folder */
    if (vdbs_scene_parse(json, NULL, back, &err) != VDBS_OK)
        fail_msg("%s\nin: %s", err.message, json);
    assert_scene_equal(s, back);
    free(json);
    free(back);
}

static void test_round_trip(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};

    round_trip(s); /* defaults */

    assert_int_equal(vdbs_scene_parse(sketch, "/data/scenes", s, &err), VDBS_OK);
    round_trip(s);
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);
    round_trip(s); /* normalised directions need 17 digits */

    /* values whose shortest decimal form needs 16-17 digits, and extremes */
    s->density_scale = 0.1 + 0.2;
    s->albedo[0] = 1.0 / 3.0;
    s->albedo[1] = 0.0;
    s->albedo[2] = 1.0;
    s->g = -2.0 / 3.0;
    s->lights[0].color[0] = 1e-300;
    s->lights[0].color[1] = 1.7976931348623157e308;
    s->lights[0].color[2] = 4.9e-324;
    s->lights[0].angular_diameter_deg = 0.53;
    s->lights[1].position[0] = -0.0;
    s->lights[1].position[2] = -123456.789012345678;
    s->camera.fov_deg = 35.000000000000007;
    s->camera.width = 1;
    s->camera.height = 16384;
    snprintf(s->method, sizeof s->method, "%s", "fld");
    snprintf(s->quality, sizeof s->quality, "%s", "ultra");
    round_trip(s);

    /* every POP setting away from its default */
    static const struct {
        const char *key;
        double value;
    } away[] = {{"pop_res", 7},          {"pop_ordinates", 24},
                {"pop_iterations", 99},  {"pop_decay", 1},
                {"pop_tally", 1},        {"pop_radial", 24},
                {"pop_importance", 1},   {"fld_res", 40},
                {"fld_limiter", 1},      {"fld_l1", 1},
                {"fld_p1", 1},           {"svd_directions", 96},
                {"svd_terms", 40},       {"svd_res", 20},
                {"svd_iterations", 300}, {"svd_residual", 1.0 / 3.0}};
    for (size_t i = 0; i < sizeof away / sizeof away[0]; ++i)
        assert_int_equal(vdbs_solver_set(s, away[i].key, away[i].value, &err), VDBS_OK);
    round_trip(s);

    /* grid names with an index, and with an '@' of their own */
    assert_int_equal(vdbs_scene_set_grid(s, "density@3", &err), VDBS_OK);
    round_trip(s);
    assert_int_equal(vdbs_scene_set_grid(s, "a@b@0", &err), VDBS_OK);
    assert_string_equal(s->grid, "a@b");
    round_trip(s);

    /* every occluder type, a fog with a box, numbers that need 17 digits */
    const char *occ =
        "{\"lights\": [{\"type\": \"sun\", \"direction\": [0.3, -1, 0.2]}],"
        " \"occluders\": ["
        "  {\"type\": \"obj\", \"file\": \"pillar.obj\", \"translate\": [0.1, 0.2, 0.3],"
        "   \"scale\": [1, 2, 3], \"rotate_deg\": [10, 20, 30], \"albedo\": [0.1, 0.2, 0.3]},"
        "  {\"type\": \"sphere\", \"center\": [1, 2, 3], \"radius\": 0.3333333333333333},"
        "  {\"type\": \"box\", \"min\": [-1, -2, -3], \"max\": [1, 2, 3], \"albedo\": 0},"
        "  {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0.1, 1, 0.2]}],"
        " \"fog\": {\"sigma_t\": 0.05, \"albedo\": [0.9, 0.8, 0.7],"
        "          \"box\": {\"min\": [-5, -1, -5], \"max\": [5, 4, 5]}}}";
    vdbs_scene *o = new_scene();
    assert_int_equal(vdbs_scene_parse(occ, "/scenes", o, &err), VDBS_OK);
    round_trip(o);
    assert_int_equal(vdbs_scene_validate(o, &err), VDBS_OK);
    round_trip(o); /* the normalised plane normal */
    o->fog.has_box = 0;
    o->fog.sigma_t = 0.0;
    round_trip(o);
    o->fog.present = 0;
    o->occluder_count = 1;
    round_trip(o);
    free(o);

    /* strings that need escaping, many lights, no camera */
    snprintf(s->volume_file, sizeof s->volume_file, "%s", "/tmp/we\"ird\\name\tx.vdb");
    s->camera.present = 0;
    s->light_count = VDBS_MAX_LIGHTS;
    for (int i = 4; i < VDBS_MAX_LIGHTS; ++i) {
        s->lights[i] = s->lights[i % 4];
        if (s->lights[i].env_map)
            s->lights[i].env_scale = i * 0.1; /* a map's colour is not stored */
        else
            s->lights[i].color[0] = i * 0.1;
    }
    round_trip(s);
    free(s);
}

static void test_grid_spec(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    assert_int_equal(vdbs_scene_set_grid(s, "density@2", &err), VDBS_OK);
    assert_string_equal(s->grid, "density");
    assert_int_equal(s->grid_index, 2);
    assert_int_equal(vdbs_scene_set_grid(s, "temperature", &err), VDBS_OK);
    assert_string_equal(s->grid, "temperature");
    assert_int_equal(s->grid_index, 0);

    const char *const bad[] = {"density@x",  "density@",           "@2", "", "density@-1",
                               "density@1x", "density@99999999999"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        char quoted[64];
        assert_int_equal(vdbs_scene_set_grid(s, bad[i], &err), VDBS_ERR_INPUT);
        snprintf(quoted, sizeof quoted, "\"%s\"", bad[i]);
        assert_contains(err.message, quoted);
        assert_true(strncmp(err.message, "scene: ", 7) == 0);
        /* the previous grid stays */
        assert_string_equal(s->grid, "temperature");
    }

    assert_int_equal(vdbs_scene_parse("{\"volume\": {\"grid\": \"density@2\"}}", NULL, s, &err),
                     VDBS_OK);
    assert_string_equal(s->grid, "density");
    assert_int_equal(s->grid_index, 2);
    free(s);
}

/* Typos get the nearest valid word; far-off words get none; lists name every valid key. */
static void test_suggestions(void **state)
{
    (void)state;
    static const char *const flags[] = {"--density-scale", "--albedo", "--g", "--sun", NULL};
    assert_string_equal(vdbs_suggest("--densty-scale", flags), "--density-scale");
    assert_string_equal(vdbs_suggest("--albdeo", flags), "--albedo");
    assert_string_equal(vdbs_suggest("--dens", flags), "--density-scale");
    assert_null(vdbs_suggest("--camera", flags));
    assert_null(vdbs_suggest("", flags));

    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    assert_int_equal(vdbs_scene_parse("{\"volume\": {\"densty_scale\": 3}}", NULL, s, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "did you mean \"density_scale\"?"));
    assert_non_null(strstr(err.message, "file, grid, density_scale, albedo, g"));
    assert_int_equal(vdbs_scene_parse("{\"solver\": {\"method\": \"fdl\"}}", NULL, s, &err),
                     VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "solver.method"));
    assert_non_null(strstr(err.message, "did you mean \"fld\"?"));
    assert_non_null(strstr(err.message, "single, pop, fld, svd, inet"));
    /* A flag's error names the flag, not a key path. */
    assert_int_equal(vdbs_scene_set_quality(s, "--quality", "hihg", &err), VDBS_ERR_INPUT);
    assert_string_equal(err.message, "--quality: unknown quality \"hihg\" (did you mean "
                                     "\"high\"?) (expected one of: low, medium, high, ultra)");
    assert_string_equal(s->quality, "low");
    free(s);
}

/* "auto:TAU" in a scene file and through the setter; refused forms leave the scene as it was. */
static void test_density_auto(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    assert_int_equal(
        vdbs_scene_parse("{\"volume\": {\"density_scale\": \"auto:12.5\"}}", NULL, s, &err),
        VDBS_OK);
    assert_true(s->density_target_depth == 12.5);
    char *json = vdbs_scene_to_json(s);
    assert_non_null(strstr(json, "\"density_scale\":\"auto:12.5\""));
    free(json);
    assert_int_equal(vdbs_scene_set_density_scale(s, "--density-scale", "7", &err), VDBS_OK);
    assert_true(s->density_scale == 7.0 && s->density_target_depth == 0.0);
    const char *bad[] = {"auto:", "auto:0", "auto:-1", "auto:x", "-1", "nan", "auto:inf", ""};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        assert_int_equal(vdbs_scene_set_density_scale(s, "--density-scale", bad[i], &err),
                         VDBS_ERR_INPUT);
        assert_non_null(strstr(err.message, "--density-scale"));
        assert_true(s->density_scale == 7.0 && s->density_target_depth == 0.0);
    }
    free(s);
}

static void test_quality(void **state)
{
    (void)state;
    assert_int_equal(vdbs_quality_sky_directions("low"), 16);
    assert_int_equal(vdbs_quality_sky_directions("medium"), 64);
    assert_int_equal(vdbs_quality_sky_directions("high"), 256);
    assert_int_equal(vdbs_quality_sky_directions("ultra"), 1024);
    assert_int_equal(vdbs_quality_sky_directions("Medium"), 0);
    assert_int_equal(vdbs_quality_sky_directions(""), 0);
    assert_int_equal(vdbs_quality_sky_directions(NULL), 0);
}

/* Env-map paths live once in the scene, not in every light: the scene stays small enough
 * to copy by value, and lights refer to their paths by env_map. */
static void test_env_paths(void **state)
{
    (void)state;
    assert_true(sizeof(vdbs_scene) <= 32 * 1024);

    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    const char *json =
        "{\"lights\": [{\"type\": \"env\", \"file\": \"/maps/day.exr\", \"scale\": 2},"
        " {\"type\": \"sun\", \"direction\": [0,-1,0]},"
        " {\"type\": \"env\", \"file\": \"night.exr\", \"scale\": 0.5},"
        " {\"type\": \"env\", \"file\": \"/maps/day.exr\"},"
        " {\"type\": \"env\", \"color\": 0.1}]}";
    assert_int_equal(vdbs_scene_parse(json, "/scenes", s, &err), VDBS_OK);
    assert_string_equal(vdbs_light_env_file(s, &s->lights[0]), "/maps/day.exr");
    assert_string_equal(vdbs_light_env_file(s, &s->lights[1]), "");
    assert_string_equal(vdbs_light_env_file(s, &s->lights[2]), "/scenes/night.exr");
    assert_string_equal(vdbs_light_env_file(s, &s->lights[3]), "/maps/day.exr");
    assert_string_equal(vdbs_light_env_file(s, &s->lights[4]), "");
    assert_int_equal(s->lights[3].env_map, s->lights[0].env_map); /* stored once */
    assert_int_equal(s->lights[4].env_map, 0);

    /* both maps survive to_json and parse, and a copy by value */
    round_trip(s);
    vdbs_scene *copy = new_scene();
    *copy = *s;
    assert_string_equal(vdbs_light_env_file(copy, &copy->lights[2]), "/scenes/night.exr");

    /* copying lights between scenes brings their paths; a bare copy of a light does not */
    vdbs_scene *other = new_scene();
    vdbs_scene_copy_lights(other, s);
    assert_int_equal(other->light_count, 5);
    assert_scene_equal(other, s);
    vdbs_scene_clear_lights(other);
    assert_int_equal(other->light_count, 0);
    other->lights[0] = s->lights[2];
    other->light_count = 1;
    assert_string_equal(vdbs_light_env_file(other, &other->lights[0]), "");
    assert_int_equal(vdbs_scene_validate(other, &err), VDBS_ERR_INTERNAL);
    assert_contains(err.message, "lights[0]");

    /* the setter: "" is a constant env; two paths of the longest length fit, a third not */
    assert_int_equal(vdbs_light_set_env_file(other, &other->lights[0], "", &err), VDBS_OK);
    assert_int_equal(other->lights[0].env_map, 0);
    assert_int_equal(vdbs_scene_validate(other, &err), VDBS_OK);
    char *long_path = malloc(VDBS_PATH_MAX + 1);
    assert_non_null(long_path);
    memset(long_path, 'a', VDBS_PATH_MAX);
    long_path[VDBS_PATH_MAX] = '\0';
    assert_int_equal(vdbs_light_set_env_file(other, &other->lights[0], long_path, &err),
                     VDBS_ERR_INPUT);
    for (int i = 0; i < 3; ++i) {
        long_path[VDBS_PATH_MAX - 1] = '\0';
        long_path[0] = (char)('a' + i);
        vdbs_status st = vdbs_light_set_env_file(other, &other->lights[i], long_path, &err);
        assert_int_equal(st, i < 2 ? VDBS_OK : VDBS_ERR_INPUT);
    }
    assert_int_equal(other->lights[2].env_map, 0); /* unchanged on error */
    assert_int_equal(strlen(vdbs_light_env_file(other, &other->lights[1])), VDBS_PATH_MAX - 1);
    assert_true(vdbs_light_env_file(other, &other->lights[1])[0] == 'b');

    /* a scene file whose paths do not fit names the light */
    char *big = malloc(3 * VDBS_PATH_MAX + 256);
    assert_non_null(big);
    int n = sprintf(big, "{\"lights\": [");
    for (int i = 0; i < 3; ++i) {
        long_path[1] = (char)('a' + i);
        n += sprintf(big + n, "%s{\"type\": \"env\", \"file\": \"/%s\"}", i ? ", " : "",
                     long_path + 1);
    }
    sprintf(big + n, "]}");
    assert_int_equal(vdbs_scene_parse(big, NULL, copy, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "lights[2].file");
    assert_string_equal(vdbs_light_env_file(copy, &copy->lights[2]), "/scenes/night.exr");
    free(big);
    free(long_path);
    free(other);
    free(copy);
    free(s);
}

/* Occluders and fog: every type, defaults, resolved OBJ paths stored once, and ranges
 * of values set by code checked by vdbs_scene_validate. */
/* Every error message is one line of valid UTF-8 (vdbs_error_clean, applied by
 * vdbs_error_set): control characters and stray bytes become '?', UTF-8 stays, and a sequence
 * cut by a quoting limit does not leave half a character. */
static void test_error_messages_clean(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_error_set(&err, VDBS_ERR_INPUT, "key \"%s\"",
                   "a\nb\x01\x7f\xff\xc3\xa9\xe2\x82\xac\xe2\x82");
    assert_string_equal(err.message, "key \"a?b???\xc3\xa9\xe2\x82\xac??\"");
    /* A key of 300 bytes of 0xb2 through the parser: quoted to 64 bytes, all '?'. */
    char json[400] = "{\"";
    memset(json + 2, 0xb2, 300);
    strcpy(json + 302, "\": 1}");
    vdbs_scene scene;
    assert_int_equal(vdbs_scene_parse(json, NULL, &scene, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message,
                           "\"????????????????????????????????????????????????????????????????\""));
    /* --grid of 1000 characters: quoted to 64. */
    char grid[1001];
    memset(grid, 'd', 1000);
    grid[1000] = '\0';
    vdbs_scene_init(&scene);
    assert_int_equal(vdbs_scene_set_grid(&scene, grid, &err), VDBS_ERR_INPUT);
    assert_true(strlen(err.message) < 200);
    /* A message longer than the buffer is cut visibly, and stays under its last byte (the
     * fuzz harnesses take a full buffer for a cut message). */
    char value[3 * VDBS_ERROR_MAX];
    memset(value, 'v', sizeof value - 1);
    value[sizeof value - 1] = '\0';
    vdbs_error_set(&err, VDBS_ERR_INPUT, "--x: got '%s'", value);
    const size_t len = strlen(err.message);
    assert_true(len < VDBS_ERROR_MAX - 1);
    assert_string_equal(err.message + len - 6, " [...]");
    /* Exactly as long as the buffer holds (the fuzz finding): cut as well. */
    value[VDBS_ERROR_MAX - 1 - 11] = '\0';
    vdbs_error_set(&err, VDBS_ERR_INPUT, "--x: got '%s'", value);
    assert_true(strlen(err.message) < VDBS_ERROR_MAX - 1);
}

static void test_occluders_and_fog(void **state)
{
    (void)state;
    vdbs_scene *s = new_scene();
    vdbs_error err = {{0}};
    const char *json =
        "{\"occluders\": ["
        "  {\"type\": \"obj\", \"file\": \"meshes/pillar.obj\"},"
        "  {\"type\": \"obj\", \"file\": \"meshes/pillar.obj\", \"translate\": [1, 0, 0],"
        "   \"scale\": 2, \"rotate_deg\": [0, 90, 0], \"albedo\": 0.8},"
        "  {\"type\": \"sphere\", \"center\": [0, 1, 0], \"radius\": 0.5},"
        "  {\"type\": \"box\", \"min\": [0, 0, 0], \"max\": [1, 2, 3], \"albedo\": [0.1, 0.2, "
        "0.3]},"
        "  {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0, 2, 0]},"
        "  {\"type\": \"obj\", \"file\": \"/abs/rock.obj\"}],"
        " \"fog\": {\"sigma_t\": 0.02}}";
    assert_int_equal(s->occluder_count, 0); /* none by default */
    assert_int_equal(s->fog.present, 0);
    if (vdbs_scene_parse(json, "/scenes", s, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(s->occluder_count, 6);
    const vdbs_occluder *o = s->occluders;
    assert_int_equal(o[0].type, VDBS_OCCLUDER_OBJ);
    assert_string_equal(vdbs_occluder_obj_file(s, &o[0]), "/scenes/meshes/pillar.obj");
    assert_int_equal(o[1].obj_file, o[0].obj_file); /* one path, stored once */
    assert_string_equal(vdbs_occluder_obj_file(s, &o[5]), "/abs/rock.obj");
    assert_string_equal(vdbs_occluder_obj_file(s, &o[2]), ""); /* not an obj */
    assert_vec3(o[0].translate, 0, 0, 0);
    assert_vec3(o[0].scale, 1, 1, 1);
    assert_vec3(o[0].rotate_deg, 0, 0, 0);
    assert_vec3(o[0].albedo, 0.5, 0.5, 0.5);
    assert_vec3(o[1].translate, 1, 0, 0);
    assert_vec3(o[1].scale, 2, 2, 2);
    assert_vec3(o[1].rotate_deg, 0, 90, 0);
    assert_vec3(o[1].albedo, 0.8, 0.8, 0.8);
    assert_int_equal(o[2].type, VDBS_OCCLUDER_SPHERE);
    assert_vec3(o[2].center, 0, 1, 0);
    assert_true(o[2].radius == 0.5);
    assert_vec3(o[2].albedo, 0.5, 0.5, 0.5);
    assert_int_equal(o[3].type, VDBS_OCCLUDER_BOX);
    assert_vec3(o[3].min, 0, 0, 0);
    assert_vec3(o[3].max, 1, 2, 3);
    assert_vec3(o[3].albedo, 0.1, 0.2, 0.3);
    assert_int_equal(o[4].type, VDBS_OCCLUDER_PLANE);
    assert_vec3(o[4].point, 0, -1, 0);
    assert_vec3(o[4].normal, 0, 2, 0); /* normalised by validate, not by parse */
    assert_int_equal(s->fog.present, 1);
    assert_true(s->fog.sigma_t == 0.02);
    assert_vec3(s->fog.albedo, 1, 1, 1); /* default: scatters, absorbs nothing */
    assert_int_equal(s->fog.has_box, 0); /* the volume's bounds */

    s->lights[0].type = VDBS_LIGHT_SUN;
    s->lights[0].direction[1] = -1.0;
    s->lights[0].color[0] = s->lights[0].color[1] = s->lights[0].color[2] = 1.0;
    s->light_count = 1;
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);
    assert_vec3(s->occluders[4].normal, 0, 1, 0);

    /* light copies leave the OBJ paths alone */
    vdbs_scene *other = new_scene();
    vdbs_scene_copy_lights(s, other);
    vdbs_scene_clear_lights(s);
    assert_string_equal(vdbs_occluder_obj_file(s, &o[0]), "/scenes/meshes/pillar.obj");

    /* values set by code are validated, naming the key; a failure normalises nothing */
    s->light_count = 1;
    s->lights[0] = other->lights[0];
    s->lights[0].type = VDBS_LIGHT_ENV;
    s->lights[0].color[0] = 1.0;
    s->occluders[4].normal[1] = 3.0;
    const struct {
        double *field;
        double bad;
        const char *message;
    } cases[] = {
        {&s->occluders[2].radius, -1.0, "scene: occluders[2].radius: must be finite and > 0"},
        {&s->occluders[2].radius, NAN, "scene: occluders[2].radius:"},
        {&s->occluders[2].center[0], INFINITY, "scene: occluders[2].center: must be 3 finite"},
        {&s->occluders[3].max[2], 0.0, "scene: occluders[3].max: must exceed min"},
        {&s->occluders[3].min[0], NAN, "scene: occluders[3].min: must be 3 finite"},
        {&s->occluders[1].scale[1], 0.0, "scene: occluders[1].scale:"},
        {&s->occluders[1].rotate_deg[1], NAN, "scene: occluders[1].rotate_deg:"},
        {&s->occluders[1].translate[0], -INFINITY, "scene: occluders[1].translate:"},
        {&s->occluders[0].albedo[2], 1.5, "scene: occluders[0].albedo:"},
        {&s->occluders[4].normal[1], 0.0, "scene: occluders[4].normal: must be a non-zero"},
        {&s->fog.sigma_t, -1.0, "scene: fog.sigma_t:"},
        {&s->fog.albedo[0], NAN, "scene: fog.albedo:"},
    };
    vdbs_scene *copy = new_scene();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        double keep = *cases[i].field;
        *cases[i].field = cases[i].bad;
        memcpy(copy, s, sizeof *s);
        if (vdbs_scene_validate(s, &err) != VDBS_ERR_INPUT)
            fail_msg("case %zu (%s): validates", i, cases[i].message);
        assert_contains(err.message, cases[i].message);
        assert_memory_equal(s, copy, sizeof *s);
        *cases[i].field = keep;
    }
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_OK);
    s->fog.has_box = 1; /* a box of zeros */
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "scene: fog.box.max: must exceed min");
    s->fog.has_box = 0;
    s->occluders[5].obj_file = 9999; /* not a path of this scene */
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INTERNAL);
    assert_contains(err.message, "occluders[5]");
    s->occluders[5].type = (vdbs_occluder_type)7;
    assert_int_equal(vdbs_scene_validate(s, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "occluders[5].type");

    /* at most VDBS_MAX_OCCLUDERS */
    char *many = malloc((VDBS_MAX_OCCLUDERS + 1) * 80 + 64);
    assert_non_null(many);
    int n = sprintf(many, "{\"occluders\": [");
    for (int i = 0; i <= VDBS_MAX_OCCLUDERS; ++i)
        n += sprintf(many + n, "%s" SPHERE, i ? ", " : "");
    sprintf(many + n, "]}");
    assert_int_equal(vdbs_scene_parse(many, NULL, copy, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "scene: occluders: 33 occluders, at most 32");
    /* ... and the OBJ paths share VDBS_OCCLUDER_PATHS_MAX bytes */
    char *long_path = malloc(VDBS_PATH_MAX);
    assert_non_null(long_path);
    memset(long_path, 'a', VDBS_PATH_MAX - 1);
    long_path[VDBS_PATH_MAX / 2] = '\0';
    char *two = malloc(2 * VDBS_PATH_MAX + 256);
    assert_non_null(two);
    sprintf(two,
            "{\"occluders\": [{\"type\": \"obj\", \"file\": \"/%s\"}, {\"type\": \"obj\", "
            "\"file\": \"/b%s\"}]}",
            long_path, long_path);
    assert_int_equal(vdbs_scene_parse(two, NULL, copy, &err), VDBS_ERR_INPUT);
    assert_contains(err.message, "scene: occluders[1].file: the OBJ paths of a scene take at most");
    /* the setter refuses the same, leaving the occluder as it was */
    int before = s->occluders[0].obj_file;
    assert_int_equal(vdbs_occluder_set_obj_file(s, &s->occluders[0], long_path, &err), VDBS_OK);
    long_path[0] = 'b';
    assert_int_equal(vdbs_occluder_set_obj_file(s, &s->occluders[1], long_path, &err),
                     VDBS_ERR_INPUT);
    assert_int_not_equal(s->occluders[0].obj_file, before);
    assert_int_equal(s->occluders[1].obj_file, before);
    assert_int_equal(vdbs_occluder_set_obj_file(s, &s->occluders[1], "", &err), VDBS_ERR_INPUT);
    free(two);
    free(long_path);
    free(many);
    free(copy);
    free(other);
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_design_sketch),     cmocka_unit_test(test_defaults_and_scalars),
        cmocka_unit_test(test_relative_paths),    cmocka_unit_test(test_load),
        cmocka_unit_test(test_parse_errors),      cmocka_unit_test(test_validate_errors),
        cmocka_unit_test(test_round_trip),        cmocka_unit_test(test_grid_spec),
        cmocka_unit_test(test_quality),           cmocka_unit_test(test_env_paths),
        cmocka_unit_test(test_suggestions),       cmocka_unit_test(test_density_auto),
        cmocka_unit_test(test_occluders_and_fog), cmocka_unit_test(test_error_messages_clean),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
