/* The solvers' grids on a thin layer (coarse.h's vdbs_coarse_world_frame): a slab of
 * 300 x 10 x 300 voxels (optical thickness 1, albedo 1, g 0.75, the sun overhead) baked with the
 * discrete ordinates at quality high and rendered in baked mode at its centre, against
 * adding-doubling's reflected radiance (tests/planeparallel.h): the full radiance leaving the
 * slab, single and multiple scattering. The slab is 30 times wider than thick and the
 * cameras look at its centre, 15 mean free paths from its edges. */
#include "planeparallel.h"
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/bake.h"
#include "vdbscatter/image.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/vdbio.h"

#define SLAB_W 300
#define SLAB_T 10

static void write_slab(const char *path)
{
    float *values = malloc(sizeof *values * SLAB_W * SLAB_T * SLAB_W);
    assert_non_null(values);
    for (int i = 0; i < SLAB_W * SLAB_T * SLAB_W; ++i)
        values[i] = 1.0f;
    const int dims[3] = {SLAB_W, SLAB_T, SLAB_W};
    vdbs_error err;
    if (vdbio_debug_write_float_grid(path, "density", values, dims, NULL, 0.0f, 0, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    free(values);
}

/* The slab's scene: voxels of side 1, so density scale 0.1 makes its 10 voxels (the half-voxel
 * ramps included) an optical thickness of 1. across: the svd_across setting, 0 the default. */
static void slab_scene(vdbs_scene *scene, int across)
{
    vdbs_error err;
    vdbs_scene_init(scene);
    scene->density_scale = 0.1;
    scene->albedo[0] = scene->albedo[1] = scene->albedo[2] = 1.0;
    scene->g = 0.75;
    scene->light_count = 1;
    memset(&scene->lights[0], 0, sizeof scene->lights[0]);
    scene->lights[0].type = VDBS_LIGHT_SUN;
    scene->lights[0].direction[1] = -1.0;
    scene->lights[0].color[0] = scene->lights[0].color[1] = scene->lights[0].color[2] = 1.0;
    strcpy(scene->method, "svd");
    strcpy(scene->quality, "high");
    if (across > 0)
        assert_int_equal(vdbs_solver_set(scene, "svd_across", across, &err), VDBS_OK);
    assert_int_equal(vdbs_scene_validate(scene, &err), VDBS_OK);
}

/* The mean of an 8 x 8 baked render of 2 degrees looking at the slab's lit face's centre
 * along cosine mu to its normal, 30.5 units away. */
static double baked_radiance(const char *lit, const vdbs_scene *scene, double mu)
{
    const double centre[3] = {0.5 * (SLAB_W - 1), SLAB_T - 0.5, 0.5 * (SLAB_W - 1)};
    vdbs_camera camera = {0};
    camera.present = 1;
    memcpy(camera.target, centre, sizeof centre);
    camera.position[0] = centre[0] + 30.5 * sqrt(1.0 - mu * mu);
    camera.position[1] = centre[1] + 30.5 * mu;
    camera.position[2] = centre[2];
    camera.up[2] = 1.0;
    camera.fov_deg = 2.0;
    camera.width = camera.height = 8;
    const char *out = test_tmp_path("slab_grid.exr");
    vdbs_render_desc desc = {0};
    desc.input = lit;
    desc.output = out;
    desc.scene = scene;
    desc.mode = VDBS_RENDER_BAKED;
    desc.backend = VDBS_BACKEND_CPU;
    desc.camera = &camera;
    vdbs_render_report report;
    vdbs_error err;
    if (vdbs_render(&desc, &report, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_image image;
    if (vdbs_image_read(out, &image, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    double sum = 0.0;
    for (int i = 0; i < 3 * image.width * image.height; ++i)
        sum += image.rgb[i];
    const double mean = sum / (3.0 * image.width * image.height);
    vdbs_image_free(&image);
    remove(out);
    return mean;
}

/* Bakes the slab with svd_across `across` and returns the baked radiance at mu = 1 and 0.5. */
static void bake_and_look(const char *slab, int across, double radiance[2])
{
    vdbs_scene scene;
    slab_scene(&scene, across);
    const char *lit = test_tmp_path("slab_grid_lit.vdb");
    vdbs_bake_options bake = {0};
    bake.input = slab;
    bake.output = lit;
    bake.scene = &scene;
    bake.backend = VDBS_BACKEND_CPU;
    vdbs_bake_report report;
    vdbs_error err;
    if (vdbs_bake(&bake, &report, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    radiance[0] = baked_radiance(lit, &scene, 1.0);
    radiance[1] = baked_radiance(lit, &scene, 0.5);
    remove(lit);
}

/* High's default grid (12 cells through the thickness asked, 11 given: never thinner than a
 * voxel) within 5% of adding-doubling at mu = 0.5. At mu = 1 no lit VDB can be: it holds the
 * multiple scattering as a direction average and a first moment (ms, ms_l1), and the slab's
 * exact field inside, rebuilt from those two moments as every renderer of the lit VDB does,
 * reflects 40% more than adding-doubling there (5% less at mu = 0.5; pp_moments_reflection).
 * So at mu = 1 the 5% is against that: the solver against what its output format can carry.
 * Both closer than cubic cells, which leave the slab 2 cells thick. The discrete-ordinates
 * field itself is checked against adding-doubling first. */
static void test_svd_high_on_a_thin_slab(void **state)
{
    (void)state;
    const char *slab = test_tmp_path("slab_grid.vdb");
    write_slab(slab);
    const double mus[2] = {1.0, 0.5};
    double r_flux, t_flux, truth[2], t_rad[2], ordinates[2], moments[2];
    pp_adding_doubling_dirs(1.0, 1.0, 0.75, &r_flux, &t_flux, NULL, NULL, 2, mus, truth, t_rad);
    pp_moments_reflection(1.0, 1.0, 0.75, 2, mus, ordinates, moments);
    for (int i = 0; i < 2; ++i) {
        print_message("mu %.1f: adding-doubling %.6f, ordinates %.6f, from two moments %.6f\n",
                      mus[i], truth[i], ordinates[i], moments[i]);
        assert_true(fabs(ordinates[i] / truth[i] - 1.0) < 1e-3);
    }
    double boxes[2], cubes[2];
    bake_and_look(slab, 0, boxes);
    bake_and_look(slab, 1, cubes);
    remove(slab);
    /* The oracle per cosine: mu = 1 against the two moments, mu = 0.5 against the truth. */
    const double oracle[2] = {moments[0], truth[1]};
    for (int i = 0; i < 2; ++i) {
        const double e_box = boxes[i] / oracle[i] - 1.0, e_cube = cubes[i] / oracle[i] - 1.0;
        print_message("mu %.1f: oracle %.6f, svd high %.6f (%+.1f%%), cubic cells %.6f (%+.1f%%)\n",
                      mus[i], oracle[i], boxes[i], 100.0 * e_box, cubes[i], 100.0 * e_cube);
        if (!(fabs(e_box) <= 0.05))
            fail_msg("mu %.1f: svd high %.6f against %.6f (%+.1f%%, bar 5%%)", mus[i], boxes[i],
                     oracle[i], 100.0 * e_box);
        assert_true(fabs(e_box) < fabs(e_cube));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_svd_high_on_a_thin_slab),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
