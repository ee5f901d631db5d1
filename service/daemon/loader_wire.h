/* loader_wire.h — the loader child's reply on its pipe: a head (error or kind), the
 * struct, its arrays in order, a trailer. Child and parent are the same executable, so
 * structs travel as raw bytes; the parent still checks every size and index it reads
 * (a decoder exploited by a hostile file could write anything). */
#ifndef VSD_DAEMON_LOADER_WIRE_H
#define VSD_DAEMON_LOADER_WIRE_H
#include "reply.h"

enum { VSDD_WIRE_ERROR = 0, VSDD_WIRE_VOLUME, VSDD_WIRE_ENV };

/* The child's side: 0 written, -1 the pipe failed (the parent gave up). */
int vsdd_wire_put_error(int fd, const vsdd_err *e);
int vsdd_wire_put_volume(int fd, const vsd_volume *v);
int vsdd_wire_put_env(int fd, const vsd_env *env);

/* The parent's side: a pipe read against a deadline (vsd_clock_seconds). */
typedef struct vsdd_wire_in {
    int fd;
    double deadline;
    uint64_t max_bytes;   /* no array larger than the child could have held */
    int timed_out;        /* the deadline passed */
    int short_read;       /* EOF or a read error before the reply was complete */
    char why[160];        /* what was malformed, for the error message */
} vsdd_wire_in;

/* Reads one reply. Returns VSDD_WIRE_ERROR with *child_err filled (the decoder's own
 * error), VSDD_WIRE_VOLUME / VSDD_WIRE_ENV with *vol / *env set, or -1 when the reply is
 * missing, late or malformed (in->timed_out, in->short_read or in->why say which). */
int vsdd_wire_get(vsdd_wire_in *in, vsdd_err *child_err, vsd_volume **vol, vsd_env **env);

#endif
