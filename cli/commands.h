/* The vdbscatter subcommands; each returns the process exit status. */
#ifndef VDBSCATTER_CLI_COMMANDS_H
#define VDBSCATTER_CLI_COMMANDS_H

int cmd_info(int argc, char **argv);
int cmd_sample(int argc, char **argv);
int cmd_bake(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_phase_svd(int argc, char **argv);
int cmd_tradeoff(int argc, char **argv);

#endif
