/* Ctrl-C and SIGTERM: the handler only sets a flag that the library polls
 * (vdbscatter/cancel.h), so a long command stops at the next poll, removes its temporary file
 * and exits 128 + the signal (130 for SIGINT, 143 for SIGTERM) instead of dying mid-write. */
#ifndef VDBSCATTER_CLI_INTERRUPT_H
#define VDBSCATTER_CLI_INTERRUPT_H

#include "vdbscatter/cancel.h"

/* Installs the SIGINT and SIGTERM handlers; returns the flag to pass to the library (it holds
 * the signal's number once one came). Each handler resets to the default action once it has
 * run, so that a second Ctrl-C still kills a process that is stuck. */
const vdbs_cancel *cli_interrupt_install(void);

#endif
