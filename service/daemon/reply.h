/* reply.h — bottom layer: frames written to a connection (one writer at a time), and the
 * one error record every layer fills and the ERROR reply is made from. */
#ifndef VSD_DAEMON_REPLY_H
#define VSD_DAEMON_REPLY_H
#include "daemon_state.h"

/* A failure on its way to the client: a stable protocol code (VSD_E_*) and a message that
 * names the problem. code == NULL means "no error yet". */
typedef struct vsdd_err {
    const char *code;
    char msg[2048];
} vsdd_err;

/* Fill e (code, printf message); returns -1 so callers can `return vsdd_fail(...)`. */
int vsdd_fail(vsdd_err *e, const char *code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* A connection's outgoing side (c->out, this file's): made and freed with the record
 * (conns.c); closed by its reader when it ends and at shutdown (no more frames are sent,
 * and the socket's shutdown wakes a reader blocked on it). */
void vsdd_out_init(vsdd_conn *c);
void vsdd_out_destroy(vsdd_conn *c);
void vsdd_out_close(vsdd_conn *c);
int vsdd_out_closed(vsdd_conn *c);

/* Send one frame (JSON object consumed: deleted here). 0 ok, -1 connection gone. */
int vsdd_send(vsdd_conn *c, unsigned type, cJSON *json, const void *bin, size_t bin_len);
int vsdd_send2(vsdd_conn *c, unsigned type, cJSON *json, const void *a, size_t alen, const void *b, size_t blen);
/* ERROR {id, code, message} (+ extra fields from `extra`, consumed, may be NULL). */
int vsdd_send_error(vsdd_conn *c, const cJSON *id, const char *code, const char *message, cJSON *extra);
int vsdd_send_error_id(vsdd_conn *c, double id, int has_id, const char *code, const char *message, cJSON *extra);
/* PROGRESS {id, stage, fraction}. */
int vsdd_send_progress(vsdd_conn *c, double id, const char *stage, float fraction);

#endif
