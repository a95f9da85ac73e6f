/* The vdbscatter commands inside the library (vdbs_command_run, api.c): each runs from
 * its words after the command name and returns the exit status. */
#ifndef VDBSCATTER_COMMAND_COMMANDS_H
#define VDBSCATTER_COMMAND_COMMANDS_H

#include "options.h"

/* Each command's spec: its name, run, option table and help (options.h). */
const vdbs_command_spec *vdbs_command_bake(void);
const vdbs_command_spec *vdbs_command_render(void);
const vdbs_command_spec *vdbs_command_compare(void);
const vdbs_command_spec *vdbs_command_info(void);
const vdbs_command_spec *vdbs_command_sample(void);
const vdbs_command_spec *vdbs_command_tradeoff(void);
const vdbs_command_spec *vdbs_command_phase_svd(void);

#endif
