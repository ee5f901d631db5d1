/* serve_options.h — `vsd serve`'s command line (serve_options.c) into a vsdd_config. */
#ifndef VSD_DAEMON_SERVE_OPTIONS_H
#define VSD_DAEMON_SERVE_OPTIONS_H
#include "daemon_state.h"
/* Returns -1 to go on, else an exit status (0 after --help, 2 for a bad option). */
int vsdd_serve_options(int argc, char **argv, vsdd_config *cfg, char *ready_file, size_t ready_len);
#endif
