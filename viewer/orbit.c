#include "orbit.h"

#include <math.h>
#include <string.h>

#define PITCH_LIMIT 1.55 /* just short of the pole, where up +Y degenerates */

static double clamp(double x, double lo, double hi)
{
    return x < lo ? lo : x > hi ? hi : x;
}

static void direction(double yaw, double pitch, double d[3])
{
    d[0] = cos(pitch) * sin(yaw);
    d[1] = sin(pitch);
    d[2] = cos(pitch) * cos(yaw);
}

void view_orbit_from_camera(const vdbs_camera *camera, view_orbit *orbit)
{
    double d[3];
    for (int a = 0; a < 3; ++a) {
        orbit->target[a] = camera->target[a];
        d[a] = camera->position[a] - camera->target[a];
    }
    orbit->distance = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(orbit->distance > 0.0))
        orbit->distance = 1.0;
    orbit->pitch = clamp(asin(clamp(d[1] / orbit->distance, -1.0, 1.0)), -PITCH_LIMIT, PITCH_LIMIT);
    orbit->yaw = atan2(d[0], d[2]);
    orbit->fov_deg = camera->fov_deg;
}

void view_orbit_camera(const view_orbit *orbit, const vdbs_camera *size, vdbs_camera *camera)
{
    memset(camera, 0, sizeof *camera);
    double d[3];
    direction(orbit->yaw, orbit->pitch, d);
    for (int a = 0; a < 3; ++a) {
        camera->target[a] = orbit->target[a];
        camera->position[a] = orbit->target[a] + orbit->distance * d[a];
    }
    camera->up[1] = 1.0;
    camera->fov_deg = orbit->fov_deg;
    camera->width = size->width;
    camera->height = size->height;
    camera->present = 1;
}

void view_orbit_rotate(view_orbit *orbit, double dx, double dy)
{
    orbit->yaw -= 0.01 * dx;
    orbit->pitch = clamp(orbit->pitch + 0.01 * dy, -PITCH_LIMIT, PITCH_LIMIT);
}

void view_orbit_pan(view_orbit *orbit, double dx, double dy, int height)
{
    /* A drag across the window moves the target by about the visible height there. */
    double scale = 2.0 * orbit->distance *
                   tan(0.5 * orbit->fov_deg * 3.14159265358979323846 / 180.0) /
                   (height > 0 ? height : 1);
    double right[3] = {cos(orbit->yaw), 0.0, -sin(orbit->yaw)};
    double up[3] = {-sin(orbit->pitch) * sin(orbit->yaw), cos(orbit->pitch),
                    -sin(orbit->pitch) * cos(orbit->yaw)};
    for (int a = 0; a < 3; ++a)
        orbit->target[a] += scale * (-dx * right[a] + dy * up[a]);
}

void view_orbit_zoom(view_orbit *orbit, double steps)
{
    orbit->distance *= pow(0.9, steps);
}

int view_light_turn(vdbs_scene *scene, int index, const double centre[3], double yaw, double pitch)
{
    if (index < 0 || index >= scene->light_count)
        return 0;
    vdbs_light *light = &scene->lights[index];
    double v[3];
    double length = 1.0;
    if (light->type == VDBS_LIGHT_SUN) {
        /* The direction toward the sun, turned like an orbit camera. */
        for (int a = 0; a < 3; ++a)
            v[a] = -light->direction[a];
    } else if (light->type == VDBS_LIGHT_POINT) {
        for (int a = 0; a < 3; ++a)
            v[a] = light->position[a] - centre[a];
    } else {
        return 0;
    }
    length = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(length > 0.0))
        return 0;
    double cur_pitch = asin(clamp(v[1] / length, -1.0, 1.0));
    double cur_yaw = atan2(v[0], v[2]);
    double d[3];
    direction(cur_yaw + yaw, clamp(cur_pitch + pitch, -PITCH_LIMIT, PITCH_LIMIT), d);
    for (int a = 0; a < 3; ++a) {
        if (light->type == VDBS_LIGHT_SUN)
            light->direction[a] = -d[a];
        else
            light->position[a] = centre[a] + length * d[a];
    }
    return 1;
}
