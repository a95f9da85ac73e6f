/* The Wavefront OBJ reader of the occluders. */
#include "fuzz_util.h"
#include "vdbscatter/mesh.h"

#include <math.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file(data, size, ".obj");
    vdbs_error err;
    vdbs_mesh mesh = {0};
    const vdbs_mesh_transform t = {{1, 2, 3}, {2, 2, 2}, {10, 20, 30}};
    vdbs_status st = vdbs_mesh_load_obj(path, size % 2 ? &t : NULL, &mesh, &err);
    fuzz_check_error(st, &err, "vdbs_mesh_load_obj");
    if (st == VDBS_OK) {
        if (mesh.triangle_count <= 0) {
            fprintf(stderr, "fuzz: mesh accepted without triangles\n");
            abort();
        }
        for (int i = 0; i < 9 * mesh.triangle_count; ++i) {
            if (!isfinite(mesh.positions[i])) {
                fprintf(stderr, "fuzz: mesh accepted with a non-finite position\n");
                abort();
            }
        }
        vdbs_mesh_free(&mesh);
    }
    return 0;
}
