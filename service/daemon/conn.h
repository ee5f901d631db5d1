/* conn.h — one reader thread per connection (conn.c), started by the accept loop. */
#ifndef VSD_DAEMON_CONN_H
#define VSD_DAEMON_CONN_H
#include "daemon_state.h"

/* Takes over fd (closed on refusal: too many connections or shutting down); the reader
 * serves it with d. */
void vsdd_conn_start(vsdd_daemon *d, int fd, int is_tcp, const char *peer);
/* Shutdown, after the jobs stopped: every client told `shutdown`, its socket shut, and up
 * to 5 s for the reader threads to end. */
void vsdd_conn_stop_all(vsdd_daemon *d);

#endif
