#include "vdbscatter/advice.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

double vdbs_volume_mean_depth(const vdbs_volume *volume)
{
    vdbs_thickness t;
    vdbs_volume_thickness(volume, 1.0, &t);
    return vdbs_thickness_mean(&t);
}

vdbs_status vdbs_scene_fit_density(vdbs_scene *scene, const vdbs_volume *volume, vdbs_error *err)
{
    if (!(scene->density_target_depth > 0.0))
        return VDBS_OK;
    double depth = vdbs_volume_mean_depth(volume);
    if (!(depth > 0.0) || !isfinite(scene->density_target_depth / depth))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--density-scale auto:%g: grid '%s' holds no density to scale",
                              scene->density_target_depth, volume->info.name);
    scene->density_scale = scene->density_target_depth / depth;
    scene->density_target_depth = 0.0;
    return VDBS_OK;
}

static int light_is_zero(const vdbs_light *l)
{
    if (l->type == VDBS_LIGHT_ENV && !(l->env_scale > 0.0))
        return 1;
    return !(l->color[0] > 0.0 || l->color[1] > 0.0 || l->color[2] > 0.0);
}

static const char *light_type_name(const vdbs_light *l)
{
    return l->type == VDBS_LIGHT_SUN ? "sun" : l->type == VDBS_LIGHT_POINT ? "point" : "env";
}

static void say(vdbs_warn_fn warn, void *user, const char *line)
{
    if (warn)
        warn(user, line);
}

void vdbs_scene_advise(const vdbs_scene *scene, const vdbs_volume *volume, int multiple_scattering,
                       vdbs_warn_fn warn, void *warn_user, vdbs_advice *out)
{
    char line[320];
    memset(out, 0, sizeof *out);
    out->mean_depth = scene->density_scale * vdbs_volume_mean_depth(volume);
    for (int i = 0; i < scene->light_count; ++i)
        if (light_is_zero(&scene->lights[i])) {
            out->zero_lights++;
            snprintf(line, sizeof line, "lights[%d] (%s) is zero: it adds no light", i,
                     light_type_name(&scene->lights[i]));
            say(warn, warn_user, line);
        }
    if (scene->light_count > 0 && out->zero_lights == scene->light_count)
        say(warn, warn_user, "every light is zero: the result is black");
    /* One scattering event is followed by another with probability about albedo times the
     * chance of meeting the medium on the way out, taken over half the mean depth (light
     * scattered inside leaves through about half of it). The orders then form a geometric
     * series: multiple / single = q / (1 - q). For a cloud (albedo 0.99, depth 10) that is
     * about 50; for thin smoke (albedo 0.5, depth 1) 0.25. */
    double albedo = (scene->albedo[0] + scene->albedo[1] + scene->albedo[2]) / 3.0;
    double q = albedo * (1.0 - exp(-0.5 * out->mean_depth));
    out->ms_to_ss = q < 1.0 ? q / (1.0 - q) : HUGE_VAL;
    if (scene->density_scale == 0.0) {
        say(warn, warn_user, "density scale 0: the volume is empty and the result is black");
        return;
    }
    if (out->mean_depth > 0.0 && out->mean_depth < VDBS_ADVICE_DEPTH_THIN) {
        snprintf(line, sizeof line,
                 "the mean optical depth through the volume is %.3g (under %g): it will be "
                 "nearly invisible; try --density-scale auto:10",
                 out->mean_depth, VDBS_ADVICE_DEPTH_THIN);
        say(warn, warn_user, line);
    } else if (out->mean_depth > VDBS_ADVICE_DEPTH_THICK) {
        snprintf(line, sizeof line,
                 "the mean optical depth through the volume is %.3g (over %g): light reaches "
                 "only its skin; check the density scale (try --density-scale auto:10)",
                 out->mean_depth, VDBS_ADVICE_DEPTH_THICK);
        say(warn, warn_user, line);
    }
    if (!multiple_scattering && out->ms_to_ss > 1.0) {
        snprintf(line, sizeof line,
                 "--method %s leaves out multiple scattering, estimated here at %.3gx the "
                 "single scattering (albedo %.3g, mean optical depth %.3g): the result will be "
                 "too dark; use --method svd or fld",
                 scene->method, out->ms_to_ss, albedo, out->mean_depth);
        say(warn, warn_user, line);
    }
}
