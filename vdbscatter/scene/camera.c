#include "vdbscatter/camera.h"

#include <math.h>
#include <string.h>

static double normalize(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (len > 0.0)
        for (int a = 0; a < 3; ++a)
            v[a] /= len;
    return len;
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

vdbs_status vdbs_camera_frame_init(const vdbs_camera *camera, vdbs_camera_frame *frame,
                                   vdbs_error *err)
{
    memset(frame, 0, sizeof *frame);
    double up[3];
    memcpy(up, camera->up, sizeof up);
    if (up[0] == 0.0 && up[1] == 0.0 && up[2] == 0.0)
        up[1] = 1.0;
    for (int a = 0; a < 3; ++a) {
        frame->origin[a] = camera->position[a];
        frame->forward[a] = camera->target[a] - camera->position[a];
    }
    if (!(normalize(frame->forward) > 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "camera: position equals target");
    cross(frame->forward, up, frame->right);
    if (!(normalize(frame->right) > 1e-12))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "camera: up is parallel to the view direction");
    cross(frame->right, frame->forward, frame->up);
    normalize(frame->up);
    if (!(camera->fov_deg > 0.0 && camera->fov_deg < 180.0) || camera->width < 1 ||
        camera->height < 1)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "camera: bad field of view or image size");
    frame->tan_half_y = tan(0.5 * camera->fov_deg * 3.14159265358979323846 / 180.0);
    frame->tan_half_x = frame->tan_half_y * camera->width / camera->height;
    frame->width = camera->width;
    frame->height = camera->height;
    return VDBS_OK;
}

void vdbs_camera_frame_volume(const vdbs_volume *volume, int width, int height, vdbs_camera *camera)
{
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (int corner = 0; corner < 8; ++corner) {
        double ijk[3], w[3];
        for (int a = 0; a < 3; ++a)
            ijk[a] =
                (corner >> a & 1) ? volume->info.bbox_max[a] + 1.0 : volume->info.bbox_min[a] - 1.0;
        vdbs_volume_world_point(volume, ijk, w);
        for (int a = 0; a < 3; ++a) {
            lo[a] = fmin(lo[a], w[a]);
            hi[a] = fmax(hi[a], w[a]);
        }
    }
    double centre[3], radius = 0.0;
    for (int a = 0; a < 3; ++a) {
        centre[a] = 0.5 * (lo[a] + hi[a]);
        radius += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    radius = sqrt(radius);
    memset(camera, 0, sizeof *camera);
    camera->present = 1;
    camera->fov_deg = 35.0;
    camera->width = width;
    camera->height = height;
    /* Distance at which the bounding sphere fits the vertical field of view. */
    double dist = radius / sin(0.5 * camera->fov_deg * 3.14159265358979323846 / 180.0);
    double view[3] = {0.0, 0.25, 1.0};
    normalize(view);
    for (int a = 0; a < 3; ++a) {
        camera->target[a] = centre[a];
        camera->position[a] = centre[a] + dist * view[a];
    }
    camera->up[1] = 1.0;
}

void vdbs_camera_ray(const vdbs_camera_frame *frame, double px, double py, double dir[3])
{
    double sx = (2.0 * px / frame->width - 1.0) * frame->tan_half_x;
    double sy = (1.0 - 2.0 * py / frame->height) * frame->tan_half_y;
    for (int a = 0; a < 3; ++a)
        dir[a] = frame->forward[a] + sx * frame->right[a] + sy * frame->up[a];
    normalize(dir);
}
