/* The viewer's camera and light controls as plain math (no GL), so that tests can drive
 * them: an orbit camera around a target, and a light moved by yaw and pitch. */
#ifndef VDBSCATTER_VIEWER_ORBIT_H
#define VDBSCATTER_VIEWER_ORBIT_H

#include "vdbscatter/scene.h"

typedef struct view_orbit {
    double target[3];
    double distance;
    double yaw, pitch; /* radians; the camera sits at target + distance * dir(yaw, pitch) */
    double fov_deg;
} view_orbit;

/* The orbit that reproduces `camera` (position, target, fov). */
void view_orbit_from_camera(const vdbs_camera *camera, view_orbit *orbit);
/* The camera of the orbit (up +Y; width and height copied from `size`). */
void view_orbit_camera(const view_orbit *orbit, const vdbs_camera *size, vdbs_camera *camera);
/* Mouse drags in pixels of a window `height` pixels tall. */
void view_orbit_rotate(view_orbit *orbit, double dx, double dy);
void view_orbit_pan(view_orbit *orbit, double dx, double dy, int height);
void view_orbit_zoom(view_orbit *orbit, double steps);

/* Turns light `index` by yaw and pitch (radians): a sun's direction about +Y and its own
 * horizontal axis; a point light about `centre` (its distance kept). Returns 0 when the
 * light cannot move (an env light). */
int view_light_turn(vdbs_scene *scene, int index, const double centre[3], double yaw, double pitch);

#endif
