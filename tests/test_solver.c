/* The solver table (solver.h): the entries' presets are the solvers' own rules, options keep
 * their ranges, keys and flags are unique, and registration refuses what would clash. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "vdbscatter/inet.h"
#include "vdbscatter/pop.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/solver.h"
#include "vdbscatter/svd.h"

static const vdbs_solver_option *option(const char *key)
{
    const vdbs_solver_option *o = vdbs_solver_option_by_key(key, NULL);
    assert_non_null(o);
    return o;
}

/* The value an unset option takes at a quality step. */
static double preset(const char *key, int level)
{
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    int count = 0;
    const vdbs_quality *q = vdbs_quality_list(&count);
    return vdbs_solver_option_value(&scene, option(key), &q[level]);
}

static void test_presets_are_the_solvers(void **state)
{
    (void)state;
    int count = 0;
    const vdbs_quality *q = vdbs_quality_list(&count);
    assert_int_equal(count, VDBS_QUALITY_COUNT);
    for (int level = 0; level < count; ++level) {
        int ordinates = 0, radial = 0;
        double epsilon_l = 0.0;
        vdbs_pop_quality(q[level].name, &ordinates, &epsilon_l, &radial);
        assert_true(preset("pop_ordinates", level) == ordinates);
        assert_true(preset("pop_radial", level) == radial);
        vdbs_svd_preset svd;
        vdbs_svd_quality(q[level].name, &svd);
        assert_true(preset("svd_directions", level) == svd.directions);
        assert_true(preset("svd_res", level) == svd.resolution);
        assert_true(preset("svd_across", level) == svd.across);
        assert_true(preset("svd_residual", level) == svd.residual);
        vdbs_inet_preset inet;
        vdbs_inet_quality(q[level].name, &inet);
        assert_true(preset("inet_particles", level) == (double)inet.particles);
        assert_true(preset("inet_directions", level) == inet.directions);
        assert_true(preset("inet_residual", level) == inet.residual);
        /* the solver's own rule: no preset */
        assert_true(preset("fld_res", level) == 0.0);
        assert_true(preset("svd_terms", level) == 0.0);
    }
}

/* A ladder's stop: above it the solver bakes the stop's settings, below it its own; a solver
 * without a stop bakes every quality as asked. */
static void test_ladder_stop(void **state)
{
    (void)state;
    int count = 0;
    const vdbs_quality *q = vdbs_quality_list(&count);
    const vdbs_solver *inet = vdbs_solver_find("inet"), *pop = vdbs_solver_find("pop");
    const vdbs_solver *svd = vdbs_solver_find("svd");
    assert_non_null(inet);
    assert_non_null(pop);
    assert_string_equal(inet->ladder_stop, "low");
    assert_string_equal(pop->ladder_stop, "low");
    const int stop = vdbs_quality_level(inet->ladder_stop);
    for (int level = 0; level < count; ++level) {
        const vdbs_quality *baked = vdbs_solver_quality(inet, &q[level]);
        assert_int_equal(vdbs_quality_level(baked->name), level < stop ? level : stop);
        assert_ptr_equal(vdbs_solver_quality(pop, &q[level]), baked);
        assert_ptr_equal(vdbs_solver_quality(svd, &q[level]), &q[level]);
        assert_ptr_equal(vdbs_solver_quality(NULL, &q[level]), &q[level]);
    }
    assert_null(vdbs_solver_quality(inet, NULL));
}

static void test_keys_and_flags_unique(void **state)
{
    (void)state;
    const vdbs_solver *s, *t;
    int options = 0;
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m)
        for (int i = 0; i < s->option_count; ++i, ++options) {
            const vdbs_solver_option *o = &s->options[i];
            assert_int_equal(strncmp(o->flag, "--", 2), 0);
            assert_true(strlen(o->key) < sizeof((vdbs_solver_setting *)0)->key);
            assert_ptr_equal(vdbs_solver_option_by_key(o->key, &t), o);
            assert_ptr_equal(t, s);
            assert_ptr_equal(vdbs_solver_option_by_flag(o->flag, &t), o);
            char help[1024];
            vdbs_solver_option_help(o, help, sizeof help);
            assert_non_null(strstr(help, o->flag));
        }
    assert_int_equal(options, 27);
    /* cost hints: measured, and a higher quality never costs less */
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m)
        for (int q = 0; q < VDBS_QUALITY_COUNT; ++q) {
            assert_true(s->cost[q] > 0.0);
            assert_true(q == 0 || s->cost[q] >= s->cost[q - 1]);
            assert_true(s->cost_fixed[q] >= 0.0);
            assert_true(q == 0 || s->cost_fixed[q] >= s->cost_fixed[q - 1]);
        }
    assert_true(options <= VDBS_MAX_SOLVER_SETTINGS);
    assert_null(vdbs_solver_at(-1));
    assert_null(vdbs_solver_find("inets")); /* no entry for a method that is not implemented */
}

static void test_set_and_check(void **state)
{
    (void)state;
    vdbs_scene scene;
    vdbs_scene_init(&scene);
    vdbs_error err;
    int count = 0;
    const vdbs_quality *q = vdbs_quality_list(&count);
    /* set wins over the preset at every quality; 0 goes back to the preset */
    assert_int_equal(vdbs_solver_set(&scene, "svd_directions", 96, &err), VDBS_OK);
    for (int level = 0; level < count; ++level)
        assert_true(vdbs_solver_option_value(&scene, option("svd_directions"), &q[level]) == 96);
    assert_int_equal(vdbs_solver_set(&scene, "svd_directions", 0, &err), VDBS_OK);
    assert_true(vdbs_solver_option_value(&scene, option("svd_directions"), &q[3]) == 512);
    /* ranges, evenness, choices */
    assert_int_equal(vdbs_solver_set(&scene, "pop_res", 1, &err), VDBS_ERR_INPUT);
    assert_string_equal(err.message, "solver.pop_res: must be in 2..512, got 1");
    assert_int_equal(vdbs_solver_set(&scene, "pop_radial", 9, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "9 is odd"));
    assert_int_equal(vdbs_solver_set(&scene, "svd_residual", 1.0, &err), VDBS_ERR_INPUT);
    assert_int_equal(vdbs_solver_set(&scene, "svd_residual", NAN, &err), VDBS_ERR_INPUT);
    assert_int_equal(vdbs_solver_set(&scene, "no_such", 1, &err), VDBS_ERR_INPUT);
    assert_int_equal(
        vdbs_solver_option_choose(&scene, option("pop_decay"), "--pop-decay", "linear", &err),
        VDBS_ERR_INPUT);
    assert_string_equal(err.message,
                        "--pop-decay: unknown decay \"linear\" (expected mean-cosine or paper)");
    assert_string_equal(vdbs_solver_option_choice(&scene, option("pop_decay")), "mean-cosine");
    assert_int_equal(vdbs_solver_option_choose(&scene, option("pop_decay"), "x", "paper", &err),
                     VDBS_OK);
    assert_string_equal(vdbs_solver_option_choice(&scene, option("pop_decay")), "paper");
    /* a cross-option rule of the entry */
    assert_int_equal(vdbs_solver_set(&scene, "svd_directions", 16, &err), VDBS_OK);
    assert_int_equal(vdbs_solver_set(&scene, "svd_terms", 17, &err), VDBS_OK);
    assert_int_equal(vdbs_solver_options_check(&scene, "scene: ", &err), VDBS_ERR_INPUT);
    assert_string_equal(err.message,
                        "scene: solver.svd_terms: 17 terms for 16 directions (at most D)");
}

static vdbs_status run_nothing(const vdbs_solve *solve, void *stats, vdbs_error *err)
{
    (void)solve;
    (void)stats;
    (void)err;
    return VDBS_OK;
}

static void test_register_refuses_clashes(void **state)
{
    (void)state;
    vdbs_error err;
    static const vdbs_solver_option taken_key[] = {{.key = "pop_res", .flag = "--new-res"}};
    static const vdbs_solver_option taken_flag[] = {{.key = "new_res", .flag = "--residual"}};
    static const vdbs_solver_option fresh[] = {
        {.key = "extra_n", .flag = "--extra-n", .syntax = "N", .min = 1, .max = 9}};
    vdbs_solver s = {.name = "svd", .summary = "x", .run = run_nothing};
    assert_int_equal(vdbs_solver_register(&s, &err), VDBS_ERR_INTERNAL);
    assert_non_null(strstr(err.message, "taken"));
    s.name = "extra";
    s.options = taken_key;
    s.option_count = 1;
    assert_int_equal(vdbs_solver_register(&s, &err), VDBS_ERR_INTERNAL);
    s.options = taken_flag;
    assert_int_equal(vdbs_solver_register(&s, &err), VDBS_ERR_INTERNAL);
    s.options = fresh;
    s.stats_size = VDBS_SOLVER_STATS_MAX + 1;
    assert_int_equal(vdbs_solver_register(&s, &err), VDBS_ERR_INTERNAL);
    s.stats_size = 8;
    int before = 0;
    while (vdbs_solver_at(before))
        ++before;
    assert_int_equal(vdbs_solver_register(&s, &err), VDBS_OK);
    assert_ptr_equal(vdbs_solver_at(before), &s);
    assert_ptr_equal(vdbs_solver_find("extra"), &s);
    assert_ptr_equal(vdbs_solver_option_by_flag("--extra-n", NULL), &fresh[0]);
    char names[256];
    vdbs_solver_names(names, sizeof names);
    assert_string_equal(names, "single, pop, fld, svd, inet, extra");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_presets_are_the_solvers),  cmocka_unit_test(test_ladder_stop),
        cmocka_unit_test(test_keys_and_flags_unique),    cmocka_unit_test(test_set_and_check),
        cmocka_unit_test(test_register_refuses_clashes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
