/* placeholder: being written */
#include "commands.h"
int cmd_render(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    return cli_fail("render", 1, "not implemented yet");
}
