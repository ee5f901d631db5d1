/* conn.h — one reader thread per connection (conn.c), started by the accept loop. */
#ifndef VSD_DAEMON_CONN_H
#define VSD_DAEMON_CONN_H

/* Takes over fd (closed on refusal: too many connections or shutting down). */
void vsdd_conn_start(int fd, int is_tcp, const char *peer);

#endif
