/* conns.h — the daemon's connections (conns.c): the list, the count, the reader threads
 * alive, and the references that keep a connection record alive while its reader or a job
 * uses it. Bottom layer: jobs.c and conn.c hold and release references. */
#ifndef VSD_DAEMON_CONNS_H
#define VSD_DAEMON_CONNS_H
#include "daemon_state.h"

vsdd_conns *vsdd_conns_new(void);
void vsdd_conns_free(vsdd_conns *cs);            /* when no connection is left */

/* A new record for fd (its reader's reference held), or NULL when out of memory (fd is
 * then closed). Not yet listed. */
vsdd_conn *vsdd_conn_new(int fd, int is_tcp, const char *peer);
/* Number c and list it as one more connection with a reader; -1 when `max` are listed
 * already (max 0 refuses every one): c is then numbered, for the log, but not listed, and
 * the caller frees it with vsdd_conn_discard. */
int vsdd_conns_add(vsdd_conns *cs, vsdd_conn *c, int max);
void vsdd_conn_discard(vsdd_conn *c);            /* a record vsdd_conns_add refused: close, free */
void vsdd_conn_hold(vsdd_conns *cs, vsdd_conn *c);
/* Drop one reference; the last one closes the socket and frees the record. */
void vsdd_conn_release(vsdd_conns *cs, vsdd_conn *c);
/* The reader thread of c has ended (its reference is dropped too). */
void vsdd_conns_reader_done(vsdd_conns *cs, vsdd_conn *c);
int vsdd_conns_count(vsdd_conns *cs);
/* Shutdown: every listed connection, each with a reference held (release each, free the
 * array); NULL with *n = 0 when there is none. */
vsdd_conn **vsdd_conns_hold_all(vsdd_conns *cs, int *n);
/* Wait up to `seconds` for every reader thread to end; 0 when they all did. */
int vsdd_conns_wait_readers(vsdd_conns *cs, double seconds);
/* How many connections are listed and how many readers still run (tests, fuzzing). */
void vsdd_conns_counts(vsdd_conns *cs, int *listed, int *readers);

#endif
