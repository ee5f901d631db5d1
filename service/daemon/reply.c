/* Writing frames to a connection. A connection's out.lock serialises whole frames (reader
 * thread replies, job PROGRESS/RESULT, shutdown notices); a failed write marks it dead so
 * later frames are dropped instead of blocking anyone. c->out is this file's alone. */
#define _GNU_SOURCE
#include "reply.h"
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

int vsdd_fail(vsdd_err *e, const char *code, const char *fmt, ...)
{
    va_list ap;
    e->code = code;
    va_start(ap, fmt);
    vsnprintf(e->msg, sizeof e->msg, fmt, ap);
    va_end(ap);
    return -1;
}

void vsdd_out_init(vsdd_conn *c)
{
    vsdd_mutex_init(&c->out.lock, VSDD_RANK_CONN_WRITE);
    c->out.dead = 0;
}

void vsdd_out_destroy(vsdd_conn *c) { vsdd_mutex_destroy(&c->out.lock); }

void vsdd_out_close(vsdd_conn *c)
{
    vsdd_lock(&c->out.lock);
    __atomic_store_n(&c->out.dead, 1, __ATOMIC_RELAXED);
    shutdown(c->fd, SHUT_RDWR);
    vsdd_unlock(&c->out.lock);
}

/* Without the lock: the reader asks between frames, and must not wait behind a job's
 * RESULT going to a slow client (the flag only ever goes from 0 to 1). */
int vsdd_out_closed(vsdd_conn *c) { return __atomic_load_n(&c->out.dead, __ATOMIC_RELAXED); }

int vsdd_send2(vsdd_conn *c, unsigned type, cJSON *json, const void *a, size_t alen, const void *b, size_t blen)
{
    char *text = json ? cJSON_PrintUnformatted(json) : NULL;
    int rc = -1;
    if (json) cJSON_Delete(json);
    if (!text) return -1;
    vsdd_lock(&c->out.lock);
    if (!c->out.dead) {
        vsd_frame_header h;
        unsigned char hdr[VSD_PROTO_HEADER_SIZE];
        h.version = VSD_PROTO_VERSION;
        h.type = (uint16_t)type;
        h.json_len = (uint32_t)strlen(text);
        h.bin_len = (uint64_t)alen + blen;
        vsd_proto_pack_header(&h, hdr);
        rc = vsd_proto_write_full(c->fd, hdr, sizeof hdr) || vsd_proto_write_full(c->fd, text, h.json_len) ||
                     (alen && vsd_proto_write_full(c->fd, a, alen)) || (blen && vsd_proto_write_full(c->fd, b, blen))
                 ? -1
                 : 0;
        if (rc) {
            __atomic_store_n(&c->out.dead, 1, __ATOMIC_RELAXED);
            shutdown(c->fd, SHUT_RDWR);
            vsdd_log(VSDD_LOG_INFO, "conn %u: write failed (%s), dropping the connection", c->id, strerror(errno));
        }
    }
    vsdd_unlock(&c->out.lock);
    free(text);
    return rc;
}

int vsdd_send(vsdd_conn *c, unsigned type, cJSON *json, const void *bin, size_t bin_len)
{
    return vsdd_send2(c, type, json, bin, bin_len, NULL, 0);
}

int vsdd_send_error_id(vsdd_conn *c, double id, int has_id, const char *code, const char *message, cJSON *extra)
{
    cJSON *o = extra ? extra : cJSON_CreateObject();
    if (has_id) cJSON_AddNumberToObject(o, "id", id);
    else cJSON_AddNullToObject(o, "id");
    cJSON_AddStringToObject(o, "code", code);
    cJSON_AddStringToObject(o, "message", message);
    vsdd_log(VSDD_LOG_INFO, "conn %u: error %s: %s", c->id, code, message);
    return vsdd_send(c, VSD_MSG_ERROR, o, NULL, 0);
}

int vsdd_send_error(vsdd_conn *c, const cJSON *id, const char *code, const char *message, cJSON *extra)
{
    int has = id && cJSON_IsNumber(id);
    return vsdd_send_error_id(c, has ? id->valuedouble : 0, has, code, message, extra);
}

int vsdd_send_progress(vsdd_conn *c, double id, const char *stage, float fraction)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "id", id);
    cJSON_AddStringToObject(o, "stage", stage);
    cJSON_AddNumberToObject(o, "fraction", fraction);
    return vsdd_send(c, VSD_MSG_PROGRESS, o, NULL, 0);
}
