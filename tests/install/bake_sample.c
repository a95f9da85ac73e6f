/* A program built outside the tree against an installed libvdbscatter (tests/test_install.sh
 * builds it with pkg-config and with find_package): writes the cloud sample, bakes it under a
 * sun, reads the lit VDB's radiance grid back and prints one line about it:
 *   radiance channels=3 size=NXxNYxNZ max=M finite=1
 * Usage: bake_sample DIR (the folder for x.vdb and lit.vdb). Exit 0 only when every step
 * worked and the radiance is finite and somewhere positive. */
#include <vdbscatter/vdbscatter.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

static void on_message(void *user, vdbs_message_kind kind, const char *text)
{
    (void)user;
    if (kind != VDBS_MESSAGE_OUTPUT && kind != VDBS_MESSAGE_PROGRESS)
        fputs(text, stderr);
}

static int run(int argc, const char *const *argv)
{
    vdbs_command_desc desc;
    vdbs_command_result result;
    memset(&desc, 0, sizeof desc);
    desc.argc = argc;
    desc.argv = argv;
    desc.message = on_message;
    int rc = vdbs_command_run(&desc, &result);
    if (rc != result.exit_status)
        fprintf(stderr, "bake_sample: %s returned %d but its result says %d\n", argv[0], rc,
                result.exit_status);
    if (rc != 0)
        fprintf(stderr, "bake_sample: %s exited %d: %s\n", argv[0], rc, result.error);
    vdbs_command_result_free(&result);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: bake_sample DIR\n");
        return 2;
    }
    char density[4096], lit[4096];
    snprintf(density, sizeof density, "%s/x.vdb", argv[1]);
    snprintf(lit, sizeof lit, "%s/lit.vdb", argv[1]);
    printf("version %s\n", vdbs_version());

    const char *sample[] = {"sample", "cloud", "-o", density, "--res", "24", "-q"};
    if (run((int)(sizeof sample / sizeof *sample), sample) != 0)
        return 1;
    const char *bake[] = {"bake", density, "-o", lit, "--sun", "0,-1,0", "-q"};
    if (run((int)(sizeof bake / sizeof *bake), bake) != 0)
        return 1;
    FILE *f = fopen(lit, "rb");
    if (!f) {
        fprintf(stderr, "bake_sample: bake wrote no %s\n", lit);
        return 1;
    }
    fclose(f);

    vdbs_dense_grid grid;
    vdbs_error err;
    memset(&grid, 0, sizeof grid);
    if (vdbs_dense_read(lit, "radiance", 0, &grid, &err) != VDBS_OK) {
        fprintf(stderr, "bake_sample: %s\n", err.message);
        return 1;
    }
    size_t n =
        (size_t)grid.size[0] * (size_t)grid.size[1] * (size_t)grid.size[2] * (size_t)grid.channels;
    float max = 0.0f;
    int finite = grid.values != NULL && n > 0;
    for (size_t i = 0; finite && i < n; i++) {
        if (!isfinite(grid.values[i]))
            finite = 0;
        else if (grid.values[i] > max)
            max = grid.values[i];
    }
    printf("radiance channels=%d size=%dx%dx%d max=%g finite=%d\n", grid.channels, grid.size[0],
           grid.size[1], grid.size[2], (double)max, finite);
    int ok = grid.channels == 3 && n > 0 && finite && max > 0.0f;
    vdbs_dense_free(&grid);
    return ok ? 0 : 1;
}
