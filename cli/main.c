/* vdbscatter: volume-lighting preprocessor. The commands live in the library
 * (vdbs_command_run, vdbscatter.h); this program hands them its words and prints what they say:
 * OUTPUT on stdout, the rest on stderr. */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "interrupt.h"
#include "vdbscatter/vdbscatter.h"

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

static void print_message(void *user, vdbs_message_kind kind, const char *text)
{
    (void)user;
    FILE *to = kind == VDBS_MESSAGE_OUTPUT ? stdout : stderr;
    fputs(text, to);
    fflush(to);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage, stderr);
        return 2;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 || strcmp(cmd, "help") == 0) {
        fputs(usage, stdout);
        return 0;
    }
    if (strcmp(cmd, "--version") == 0) {
        printf("vdbscatter %s\n", vdbs_version());
        return 0;
    }
    vdbs_command_desc desc = {0};
    desc.argc = argc - 1;
    desc.argv = (const char *const *)argv + 1;
    desc.message = print_message;
    desc.cancel = cli_interrupt_install();
    desc.progress = isatty(STDERR_FILENO);
    vdbs_command_result result;
    int status = vdbs_command_run(&desc, &result);
    vdbs_command_result_free(&result);
    if (fflush(stdout) != 0) {
        fprintf(stderr, "vdbscatter %s: cannot write to stdout\n", cmd);
        return status ? status : 1;
    }
    return status;
}
