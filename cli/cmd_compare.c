/* placeholder: being written */
#include "commands.h"
int cmd_compare(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    return cli_fail("compare", 1, "not implemented yet");
}
