#include "vdbscatter/single.h"

#include <stdint.h>

#include "vdbscatter/medium.h"

#define PNANOVDB_C
#include <nanovdb/PNanoVDB.h>

#include "vs_common.h"
#include "vs_medium.h"
#include "vs_lights.h"
#include "vs_march.h"
#include "vs_single.h"

typedef struct single_job {
    const vdbs_volume *volume;
    const vs_vec4 *medium_data;
    const vs_vec4 *light_data;
    float *radiance;
} single_job;

static void single_items(void *user, uint64_t begin, uint64_t end)
{
    const single_job *job = user;
    pnanovdb_buf_t buf = pnanovdb_make_buf(job->volume->nano, job->volume->nano_size / 4);
    pnanovdb_readaccessor_t acc = vs_density_accessor(buf);
    for (uint64_t n = begin; n < end; ++n) {
        const int32_t *c = job->volume->coords + 3 * n;
        pnanovdb_vec3_t s = vs_single_average(job->medium_data, job->light_data, buf, &acc,
                                              vs_coord(c[0], c[1], c[2]));
        job->radiance[3 * n] = s.x;
        job->radiance[3 * n + 1] = s.y;
        job->radiance[3 * n + 2] = s.z;
    }
}

vdbs_status vdbs_single_scatter(vdbs_runner *runner, const vdbs_volume *volume,
                                const vdbs_scene *scene, const vdbs_light_table *lights,
                                float *radiance, vdbs_progress *progress, vdbs_error *err)
{
    vdbs_medium medium_params;
    vdbs_medium_init(&medium_params, volume, scene);
    float medium[4 * VDBS_MEDIUM_TABLE_ENTRIES];
    vdbs_medium_pack(&medium_params, medium);
    single_job job = {volume, (const vs_vec4 *)medium, (const vs_vec4 *)lights->packed, radiance};

    vdbs_kernel_desc desc = {0};
    desc.items = volume->coord_count;
    desc.user = &job;
    desc.cpu_items = single_items;
    desc.shader = "single_scatter.comp";
    desc.inputs[0] = (vdbs_kernel_input){volume->nano, volume->nano_size};
    desc.inputs[1] = (vdbs_kernel_input){medium, sizeof medium};
    desc.inputs[2] =
        (vdbs_kernel_input){lights->packed, lights->packed_entries * 4 * sizeof(float)};
    desc.inputs[3] = (vdbs_kernel_input){volume->coords, 3 * sizeof(int32_t) * volume->coord_count};
    desc.state_words = 3;
    desc.output_words = 3;
    desc.output = radiance;
    desc.units_per_dispatch = vdbs_volume_gpu_marches_per_pass(volume);
    desc.total_units = lights->direct_count + lights->ordinate_count;
    /* Short dispatches keep a display driver's watchdog quiet on real GPUs. */
    desc.gpu_chunk = 1u << 16;
    desc.progress = progress;
    return vdbs_kernel_run(runner, &desc, NULL, err);
}
