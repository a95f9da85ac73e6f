/* The vdbscatter commands inside the library (vdbs_command_run, api.c): each runs from
 * its words after the command name and returns the exit status; each has its option table. */
#ifndef VDBSCATTER_COMMAND_COMMANDS_H
#define VDBSCATTER_COMMAND_COMMANDS_H

#include "options.h"

int vdbs_command_info(int argc, char **argv);
int vdbs_command_sample(int argc, char **argv);
int vdbs_command_bake(int argc, char **argv);
int vdbs_command_render(int argc, char **argv);
int vdbs_command_compare(int argc, char **argv);
int vdbs_command_phase_svd(int argc, char **argv);
int vdbs_command_tradeoff(int argc, char **argv);

const vdbs_arg_option *vdbs_command_info_options(void);
const vdbs_arg_option *vdbs_command_sample_options(void);
const vdbs_arg_option *vdbs_command_bake_options(void);
const vdbs_arg_option *vdbs_command_render_options(void);
const vdbs_arg_option *vdbs_command_compare_options(void);
const vdbs_arg_option *vdbs_command_phase_svd_options(void);
const vdbs_arg_option *vdbs_command_tradeoff_options(void);

#endif
