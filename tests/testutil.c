#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

const char *test_data_path(const char *file)
{
    static char buf[8][4096];
    static int slot;
    char *out = buf[slot++ & 7];
    snprintf(out, 4096, "%s/%s", VDBS_TEST_DATA_DIR, file);
    return out;
}

const char *test_tmp_path(const char *file)
{
    static char buf[8][4096];
    static int slot;
    char *out = buf[slot++ & 7];
    snprintf(out, 4096, "%s/%s", VDBS_TEST_TMP_DIR, file);
    return out;
}

double test_rel_diff(double a, double b)
{
    double m = fmax(fabs(a), fabs(b));
    return m == 0.0 ? 0.0 : fabs(a - b) / m;
}

void test_add_sun_point_sky(vdbs_scene *scene)
{
    static const double sun_dir[3] = {0.3, -1.0, 0.2}, sun[3] = {3.0, 3.0, 3.0};
    static const double point_pos[3] = {0.5, 1.2, -0.3}, point[3] = {2.0, 1.0, 0.5};
    static const double sky[3] = {0.2, 0.3, 0.5};
    scene->light_count = 3;
    scene->lights[0].type = VDBS_LIGHT_SUN;
    memcpy(scene->lights[0].direction, sun_dir, sizeof sun_dir);
    memcpy(scene->lights[0].color, sun, sizeof sun);
    scene->lights[1].type = VDBS_LIGHT_POINT;
    memcpy(scene->lights[1].position, point_pos, sizeof point_pos);
    memcpy(scene->lights[1].color, point, sizeof point);
    scene->lights[2].type = VDBS_LIGHT_ENV;
    memcpy(scene->lights[2].color, sky, sizeof sky);
}

void test_load_ms_grids(const char *path, const double index_to_world[3][4], vdbs_ms_grids *ms)
{
    vdbio_lit *lit = NULL;
    vdbs_error err;
    if (vdbio_lit_open(path, &lit, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    if (vdbs_ms_grids_load(lit, index_to_world, ms, &err) != VDBS_OK)
        fail_msg("%s", err.message);
    vdbio_lit_close(lit);
    remove(path);
}
