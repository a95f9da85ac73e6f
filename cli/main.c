/* vdbscatter: volume-lighting preprocessor. The commands, the usage and --version live in the
 * library (vdbs_command_run, vdbscatter.h); this program hands them its words and prints what
 * they say: OUTPUT on stdout, the rest on stderr. */
#include <stdio.h>
#include <unistd.h>

#include "interrupt.h"
#include "vdbscatter/vdbscatter.h"

static void print_message(void *user, vdbs_message_kind kind, const char *text)
{
    (void)user;
    FILE *to = kind == VDBS_MESSAGE_OUTPUT ? stdout : stderr;
    fputs(text, to);
    fflush(to);
}

int main(int argc, char **argv)
{
    vdbs_command_desc desc = {0};
    desc.argc = argc - 1;
    desc.argv = (const char *const *)argv + 1;
    desc.message = print_message;
    desc.cancel = cli_interrupt_install();
    /* a farm's log gets timestamped lines; --progress overrides */
    desc.progress =
        isatty(STDERR_FILENO) ? VDBS_COMMAND_PROGRESS_TERMINAL : VDBS_COMMAND_PROGRESS_PLAIN;
    vdbs_command_result result;
    int status = vdbs_command_run(&desc, &result);
    vdbs_command_result_free(&result);
    if (fflush(stdout) != 0) {
        fprintf(stderr, "vdbscatter %s: cannot write to stdout\n", argc > 1 ? argv[1] : "");
        return status ? status : 1;
    }
    return status;
}
