/* listen.h — the daemon's sockets and lock file (listen.c). */
#ifndef VSD_DAEMON_LISTEN_H
#define VSD_DAEMON_LISTEN_H
#include <stddef.h>
/* flock'ed pid file: returns its fd (kept open for the daemon's life) or -1. */
int vsdd_lock_acquire(const char *lock_path, char *err, size_t errlen);
int vsdd_listen_unix(const char *path, char *err, size_t errlen);
/* Loopback only unless `any`; `bound` gets the actual HOST:PORT (port 0 picks one). */
int vsdd_listen_tcp(const char *hostport, int any, char *bound, size_t boundlen, char *err, size_t errlen);
#endif
