/* vdbscatter: volume-lighting preprocessor. Dispatches to the subcommands. */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "options.h"

#ifndef VDBSCATTER_VERSION
#define VDBSCATTER_VERSION "0"
#endif

static const char usage[] =
    "usage: vdbscatter COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  bake IN.vdb -o OUT.vdb     light a density VDB and write a lit VDB\n"
    "  render IN.vdb -o IMG.exr   ray-march or path-trace a picture of a volume\n"
    "  compare A B                error metrics of image A against reference B\n"
    "  info FILE.vdb              list grids, sizes, value ranges, optical thickness\n"
    "  sample NAME -o OUT.vdb     write a procedural sample volume\n"
    "  tradeoff IN.vdb -o DIR     every method's error against time on your scene\n"
    "  phase-svd --g G --directions D   the phase matrix's factorisation error per term\n"
    "\n"
    "Run 'vdbscatter COMMAND --help' for the options of a command.\n"
    "Exit status: 0 success, 1 failure while working, 2 bad input or usage.\n";

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage, stderr);
        return CLI_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 || strcmp(cmd, "help") == 0) {
        fputs(usage, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(cmd, "--version") == 0) {
        printf("vdbscatter %s\n", VDBSCATTER_VERSION);
        return CLI_EXIT_OK;
    }
    if (strcmp(cmd, "bake") == 0)
        return cmd_bake(argc - 2, argv + 2);
    if (strcmp(cmd, "info") == 0)
        return cmd_info(argc - 2, argv + 2);
    if (strcmp(cmd, "render") == 0)
        return cmd_render(argc - 2, argv + 2);
    if (strcmp(cmd, "compare") == 0)
        return cmd_compare(argc - 2, argv + 2);
    if (strcmp(cmd, "sample") == 0)
        return cmd_sample(argc - 2, argv + 2);
    if (strcmp(cmd, "tradeoff") == 0)
        return cmd_tradeoff(argc - 2, argv + 2);
    if (strcmp(cmd, "phase-svd") == 0)
        return cmd_phase_svd(argc - 2, argv + 2);
    fprintf(stderr, "vdbscatter: unknown command '%s' (try --help)\n", cmd);
    return CLI_EXIT_USAGE;
}
