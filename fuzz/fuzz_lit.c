/* The lit-VDB reader of render: the file (contained read), its vdbscatter_scene metadata
 * through the scene parser, and its light grids (litvdb.c) on the density's transform. */
#include "fuzz_util.h"
#include "vdbscatter/litvdb.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/vdbio.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file(data, size, ".vdb");
    vdbs_error err;
    vdbio_lit *lit = NULL;
    vdbs_status st = vdbio_lit_open(path, &lit, &err);
    fuzz_check_error(st, &err, "vdbio_lit_open");
    if (st != VDBS_OK)
        return 0;
    const char *meta = vdbio_lit_meta(lit, "vdbscatter_scene");
    if (meta) {
        vdbs_scene *scene = malloc(sizeof *scene);
        if (!scene)
            abort();
        st = vdbs_scene_parse(meta, NULL, scene, &err);
        fuzz_check_error(st, &err, "vdbs_scene_parse (metadata)");
        free(scene);
    }
    vdbio_transform t;
    if (vdbio_lit_has_grid(lit, "density") &&
        vdbio_lit_transform(lit, "density", &t, &err) == VDBS_OK) {
        vdbs_lit_grids grids = {0};
        st = vdbs_lit_grids_load(lit, t.m, 1, &grids, &err);
        fuzz_check_error(st, &err, "vdbs_lit_grids_load");
        if (st == VDBS_OK)
            vdbs_lit_grids_free(&grids);
    }
    vdbio_lit_close(lit);
    return 0;
}
