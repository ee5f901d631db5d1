/* accept.h — the accept loop (accept.c), run by serve.c's main thread (and by a thread of
 * tests that run a daemon in their own process). */
#ifndef VSD_DAEMON_ACCEPT_H
#define VSD_DAEMON_ACCEPT_H
#include "daemon_state.h"

/* Accept connections on ufd (and tfd when >= 0) until stop_fd is readable, handing each to
 * a reader thread serving d (conn.c). Returns the byte read from stop_fd (serve.c writes
 * the signal's number), or -1 when poll failed. */
int vsdd_accept_loop(vsdd_daemon *d, int stop_fd, int ufd, int tfd);

#endif
