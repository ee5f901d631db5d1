/* serve.h — the `vsd serve` subcommand (service/daemon/serve.c). */
#ifndef VSD_DAEMON_SERVE_H
#define VSD_DAEMON_SERVE_H
int vsd_cmd_serve(int argc, char **argv);
#endif
