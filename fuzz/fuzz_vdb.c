/* The OpenVDB reader through its contained path (contain.h): the grid listing of `info`
 * and the density read of bake and render. A crash inside OpenVDB comes back as an input
 * error here, which is no finding; a crash or broken error in our code is. */
#include "fuzz_util.h"
#include "vdbscatter/vdbio.h"

static void quiet(void *user, const char *message)
{
    (void)user;
    if (!message || !message[0] || strchr(message, '\n')) {
        fprintf(stderr, "fuzz: warning not one line\n");
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file(data, size, ".vdb");
    vdbs_error err;
    vdbio_grid_summary *grids = NULL;
    int count = 0;
    vdbs_status st = vdbio_list_grids(path, &grids, &count, &err);
    fuzz_check_error(st, &err, "vdbio_list_grids");
    free(grids);
    vdbio_read_options o = {0};
    o.warn = quiet;
    for (int levelset = 0; levelset < 2; ++levelset) {
        o.from_levelset = levelset;
        vdbio_density *d = NULL;
        st = vdbio_density_read(path, &o, &d, &err);
        fuzz_check_error(st, &err, "vdbio_density_read");
        if (st == VDBS_OK) {
            const vdbio_density_info *info = vdbio_density_get_info(d);
            if (info->active_voxels == 0 || !(info->value_min >= 0.0f)) {
                fprintf(stderr, "fuzz: density read accepted an empty or negative grid\n");
                abort();
            }
            vdbio_density_free(d);
        }
        if (st != VDBS_OK || count == 0)
            break;
    }
    return 0;
}
