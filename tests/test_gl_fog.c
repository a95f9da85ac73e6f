/* The homogeneous-fog kernels (shaders/vs_fog.h) in GLSL against their C twin: the same
 * header text on the same float inputs (shaders/test_fog.comp), point spans, sun spans and
 * the surface term on a few hundred random rays, g = 0.6. Agreement 1e-5 relative wherever
 * |v| >= 1e-30 (docs/design.md), or 1e-5 of the largest point span for the point spans (their
 * closed form subtracts two transmittance-weighted tails, so a short span keeps the absolute,
 * not the relative, rounding of llvmpipe's exp and atan). */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vdbscatter/fog.h"
#include "vdbscatter/gpu.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_phase.h"
#include "vs_fog.h"

#define SCENE_FLOATS 12
#define ITEM_FLOATS 16
#define ITEMS 300

static pnanovdb_vec3_t in3(const float *in, int k)
{
    return vs_vec3(in[k], in[k + 1], in[k + 2]);
}

/* The shader's main() on the C path. */
static void c_item(const float *fog_data, const float *in, int item, float out[3])
{
    int b = SCENE_FLOATS + item * ITEM_FLOATS;
    pnanovdb_vec3_t o = in3(in, b), d = in3(in, b + 4);
    out[0] =
        vs_fog_point_span(fog_data, o, d, in3(in, b + 8), 2.0f, in[b + 3], in[b + 7], in[b + 11]);
    out[1] = vs_fog_sun_span(fog_data, o, d, in3(in, 0), in[3], in3(in, 4), in3(in, 8), in[b + 14],
                             in[b + 14], in[b + 15]);
    out[2] = vs_fog_surface_indirect(fog_data, in[b + 12], in[b + 13], 2.0f, 0.7f);
}

/* Random rays from a camera inside the box [-3, 3]^3 toward points near the light, with a
 * lit span and the chord's part inside the box for the sun. */
static void make_inputs(float *in)
{
    uint64_t rng = 99;
    const float scene[SCENE_FLOATS] = {0.26f, -0.93f, 0.26f, 1.5f, -3, -3, -3, 0, 3, 3, 3, 0};
    memcpy(in, scene, sizeof scene);
    for (int i = 0; i < ITEMS; ++i) {
        float *p = in + SCENE_FLOATS + i * ITEM_FLOATS;
        double o[3], d[3], light[3] = {0.2, -0.4, 0.3};
        for (int a = 0; a < 3; ++a)
            o[a] = 4.0 * (test_uniform(&rng) - 0.5);
        for (int a = 0; a < 3; ++a)
            d[a] = light[a] + 2.0 * (test_uniform(&rng) - 0.5) - o[a];
        double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double exit = INFINITY;
        for (int a = 0; a < 3; ++a) {
            d[a] /= n;
            if (d[a] != 0.0)
                exit = fmin(exit, ((d[a] > 0.0 ? 3.0 : -3.0) - o[a]) / d[a]);
        }
        double s0 = 0.3 * test_uniform(&rng) * exit, s1 = s0 + test_uniform(&rng) * (exit - s0);
        for (int a = 0; a < 3; ++a) {
            p[a] = (float)o[a];
            p[4 + a] = (float)d[a];
            p[8 + a] = (float)light[a];
        }
        p[3] = 0.0f;
        p[7] = (float)s0;
        p[11] = i % 3 == 0 ? 1e30f : (float)s1;
        p[12] = (float)(0.1 + 20.0 * test_uniform(&rng));
        p[13] = (float)(2.0 * test_uniform(&rng) - 1.0);
        p[14] = (float)s0;
        p[15] = (float)s1;
    }
}

static void test_fog_twin(void **state)
{
    (void)state;
    vdbs_error err;
    vdbs_fog fog;
    vdbs_fog_desc desc = {.sigma_t = 0.7, .albedo = 0.9, .g = 0.6};
    assert_int_equal(vdbs_fog_build(&desc, &fog, &err), VDBS_OK);
    static float in[SCENE_FLOATS + ITEMS * ITEM_FLOATS], gpu_out[3 * ITEMS], c_out[3 * ITEMS];
    make_inputs(in);
    for (int i = 0; i < ITEMS; ++i)
        c_item(fog.table, in, i, c_out + 3 * i);

    vdbs_gpu *gpu = NULL;
    if (vdbs_gpu_create(&gpu, &err) != VDBS_OK)
        fail_msg("vdbs_gpu_create: %s", err.message);
    const vdbs_shader_source *src = vdbs_shader_find("test_fog.comp");
    assert_non_null(src);
    vdbs_gpu_program program;
    if (vdbs_gpu_program_create(gpu, src, NULL, &program, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbs_gpu_buffer nano, table, input, output;
    assert_int_equal(vdbs_gpu_buffer_create(gpu, 0, NULL, &nano, &err), VDBS_OK);
    assert_int_equal(
        vdbs_gpu_buffer_create(gpu, fog.table_floats * sizeof(float), fog.table, &table, &err),
        VDBS_OK);
    assert_int_equal(vdbs_gpu_buffer_create(gpu, sizeof in, in, &input, &err), VDBS_OK);
    assert_int_equal(vdbs_gpu_buffer_create(gpu, sizeof gpu_out, NULL, &output, &err), VDBS_OK);
    vdbs_gpu_buffer_bind(gpu, nano, 0);
    vdbs_gpu_buffer_bind(gpu, table, 1);
    vdbs_gpu_buffer_bind(gpu, input, 2);
    vdbs_gpu_buffer_bind(gpu, output, 3);
    if (vdbs_gpu_dispatch_items(gpu, program, ITEMS, 64, 0, NULL, NULL, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    assert_int_equal(vdbs_gpu_buffer_read(gpu, output, 0, sizeof gpu_out, gpu_out, &err), VDBS_OK);
    vdbs_gpu_buffer_destroy(gpu, nano);
    vdbs_gpu_buffer_destroy(gpu, table);
    vdbs_gpu_buffer_destroy(gpu, input);
    vdbs_gpu_buffer_destroy(gpu, output);
    vdbs_gpu_program_destroy(gpu, program);
    vdbs_gpu_destroy(gpu);

    double peak = 0.0, worst[3] = {0.0, 0.0, 0.0};
    int nonzero[3] = {0, 0, 0};
    for (int i = 0; i < ITEMS; ++i)
        peak = fmax(peak, c_out[3 * i]);
    for (int i = 0; i < 3 * ITEMS; ++i) {
        int kind = i % 3;
        assert_true(isfinite(gpu_out[i]) && gpu_out[i] >= 0.0f);
        assert_true(isfinite(c_out[i]) && c_out[i] >= 0.0f);
        double diff = fabs((double)gpu_out[i] - c_out[i]);
        double scale = fmax(fabs(c_out[i]), fabs(gpu_out[i]));
        if (scale < 1e-30)
            continue;
        nonzero[kind]++;
        double rel = kind == 0 ? diff / fmax(scale, peak) : diff / scale;
        if (getenv("FOG_VERBOSE") && rel > 1e-5)
            print_message("item %d kind %d gpu %.7e c %.7e\n", i / 3, kind, gpu_out[i], c_out[i]);
        worst[kind] = fmax(worst[kind], rel);
    }
    print_message("fog GLSL vs C: worst point %.2e (of the peak), sun %.2e, surface %.2e\n",
                  worst[0], worst[1], worst[2]);
    for (int k = 0; k < 3; ++k) {
        assert_true(nonzero[k] > ITEMS / 2);
        assert_true(worst[k] < 1e-5);
    }
    vdbs_fog_free(&fog);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fog_twin),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
