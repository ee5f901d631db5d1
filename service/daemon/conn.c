/* One reader thread per connection: reads frames within the limits, answers HELLO, HAS,
 * PUT, CANCEL, STATS and BYE itself and queues RENDER as a job. Anything malformed costs
 * the sender an ERROR, and the connection when the byte stream can no longer be trusted.
 * The thread is handed the daemon record and its connection; what it asks of the jobs,
 * the cache, the connection list and the counters goes through their functions. */
#define _GNU_SOURCE
#include "conn.h"
#include "cache.h"
#include "conns.h"
#include "counters.h"
#include "jobs.h"
#include "reply.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#define FRAME_TIMEOUT_MS 30000   /* the rest of a frame must follow its header within this */
#define MAX_HAS 100000

static int constant_time_equal(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b), i;
    unsigned char d = la != lb;
    for (i = 0; i < la && i < lb; i++) d |= (unsigned char)(a[i] ^ b[i]);
    return d == 0;
}

static cJSON *limits_json(const vsdd_config *cfg)
{
    cJSON *l = cJSON_CreateObject();
    cJSON_AddNumberToObject(l, "max_message_bytes", (double)cfg->max_message);
    cJSON_AddNumberToObject(l, "max_json_bytes", (double)cfg->max_json);
    cJSON_AddNumberToObject(l, "max_width", cfg->max_dim);
    cJSON_AddNumberToObject(l, "max_height", cfg->max_dim);
    cJSON_AddNumberToObject(l, "max_pixels", (double)cfg->max_pixels);
    cJSON_AddNumberToObject(l, "max_voxels", (double)cfg->max_voxels);
    cJSON_AddNumberToObject(l, "max_job_seconds", cfg->max_job_seconds);
    cJSON_AddNumberToObject(l, "queue_length", cfg->queue_max);
    cJSON_AddNumberToObject(l, "workers", cfg->workers);
    cJSON_AddNumberToObject(l, "max_connections", cfg->max_connections);
    cJSON_AddNumberToObject(l, "cache_bytes", (double)cfg->cache_bytes);
    cJSON_AddNumberToObject(l, "blob_bytes", (double)cfg->blob_bytes);
    cJSON_AddNumberToObject(l, "max_has_hashes", MAX_HAS);
    return l;
}

/* Returns 0 to keep the connection, -1 to close it. */
static int on_hello(vsdd_daemon *d, vsdd_conn *c, const cJSON *msg, const cJSON *id)
{
    const cJSON *versions = cJSON_GetObjectItemCaseSensitive(msg, "versions");
    const cJSON *token = cJSON_GetObjectItemCaseSensitive(msg, "token");
    const cJSON *client = cJSON_GetObjectItemCaseSensitive(msg, "client");
    const char *const *m;
    cJSON *o, *arr;
    int ok = 0;
    if (versions && !cJSON_IsArray(versions)) {
        vsdd_send_error(c, id, VSD_E_BAD_REQUEST, "HELLO.versions: expected an array of integers", NULL);
        return 0;
    }
    if (!versions) ok = 1;
    else {
        const cJSON *v;
        cJSON_ArrayForEach(v, versions) if (cJSON_IsNumber(v) && v->valuedouble == VSD_PROTO_VERSION) ok = 1;
    }
    if (!ok) {
        cJSON *x = cJSON_CreateObject();
        cJSON_AddItemToObject(x, "versions", cJSON_CreateIntArray((int[]){VSD_PROTO_VERSION}, 1));
        vsdd_send_error(c, id, VSD_E_VERSION, "this daemon speaks protocol version 1 only", x);
        return 0;
    }
    if (token && !cJSON_IsString(token)) {
        vsdd_send_error(c, id, VSD_E_BAD_REQUEST, "HELLO.token: expected string", NULL);
        return 0;
    }
    if (c->is_tcp && (!token || !d->cfg.token[0] || !constant_time_equal(token->valuestring, d->cfg.token))) {
        vsdd_send_error(c, id, VSD_E_AUTH, token ? "wrong token" : "TCP connections need a token in HELLO", NULL);
        vsdd_log(VSDD_LOG_WARN, "conn %u (%s): refused: %s token", c->id, c->peer, token ? "wrong" : "no");
        return -1;
    }
    c->hello_done = 1;
    vsdd_log(VSDD_LOG_INFO, "conn %u: hello from %s", c->id,
             cJSON_IsString(client) ? client->valuestring : "(unnamed client)");
    o = cJSON_CreateObject();
    if (cJSON_IsNumber(id)) cJSON_AddNumberToObject(o, "id", id->valuedouble);
    cJSON_AddNumberToObject(o, "version", VSD_PROTO_VERSION);
    cJSON_AddStringToObject(o, "server", "vsd");
    cJSON_AddStringToObject(o, "server_version", vsd_version());
    arr = cJSON_AddArrayToObject(o, "methods");
    for (m = vsd_method_names(); *m; m++) cJSON_AddItemToArray(arr, cJSON_CreateString(*m));
    {
        /* every method's option table, so clients draw their settings from it */
        char *table = vsd_method_options_json();
        cJSON *parsed = table ? cJSON_Parse(table) : NULL;
        free(table);
        if (parsed) cJSON_AddItemToObject(o, "method_options", parsed);
        /* every method's label, capabilities and options: clients build menus from it */
        table = vsd_method_catalog_json();
        parsed = table ? cJSON_Parse(table) : NULL;
        free(table);
        if (parsed) cJSON_AddItemToObject(o, "method_catalog", parsed);
    }
    arr = cJSON_AddArrayToObject(o, "devices");
    cJSON_AddItemToArray(arr, cJSON_CreateString("cpu"));
    if (d->cuda_device[0]) cJSON_AddItemToArray(arr, cJSON_CreateString("cuda"));
    if (d->cuda_device[0]) cJSON_AddStringToObject(o, "cuda_device", d->cuda_device);
    arr = cJSON_AddArrayToObject(o, "hashes");
    cJSON_AddItemToArray(arr, cJSON_CreateString("xxh3-128"));
    cJSON_AddItemToArray(arr, cJSON_CreateString("sha256"));
    arr = cJSON_AddArrayToObject(o, "capabilities");
    cJSON_AddItemToArray(arr, cJSON_CreateString("preview_png"));
    cJSON_AddItemToArray(arr, cJSON_CreateString("cancel"));
    if (d->cfg.allow_count) cJSON_AddItemToArray(arr, cJSON_CreateString("server_paths"));
    cJSON_AddItemToObject(o, "limits", limits_json(&d->cfg));
    return vsdd_send(c, VSD_MSG_HELLO, o, NULL, 0) ? -1 : 0;
}

static void on_has(vsdd_daemon *d, vsdd_conn *c, const cJSON *msg, const cJSON *id)
{
    const cJSON *hashes = cJSON_GetObjectItemCaseSensitive(msg, "hashes"), *h;
    cJSON *o, *missing;
    if (!cJSON_IsArray(hashes) || cJSON_GetArraySize(hashes) > MAX_HAS) {
        vsdd_send_error(c, id, VSD_E_BAD_REQUEST, "HAS.hashes: expected an array of at most 100000 hash strings", NULL);
        return;
    }
    cJSON_ArrayForEach(h, hashes) if (!cJSON_IsString(h) || vsd_hash_kind_of(h->valuestring) == VSD_HASH_NONE)
    {
        vsdd_send_error(c, id, VSD_E_BAD_HASH,
                        "HAS.hashes: each must be 32 (xxh3-128) or 64 (sha256) lowercase hex digits", NULL);
        return;
    }
    o = cJSON_CreateObject();
    if (cJSON_IsNumber(id)) cJSON_AddNumberToObject(o, "id", id->valuedouble);
    missing = cJSON_AddArrayToObject(o, "missing");
    cJSON_ArrayForEach(h, hashes) if (!vsdd_cache_has_blob(d->cache, h->valuestring))
        cJSON_AddItemToArray(missing, cJSON_CreateString(h->valuestring));
    vsdd_send(c, VSD_MSG_HAS, o, NULL, 0);
}

static int on_put(vsdd_daemon *d, vsdd_conn *c, const cJSON *msg, const cJSON *id, uint64_t bin_len)
{
    const cJSON *hash = cJSON_GetObjectItemCaseSensitive(msg, "hash");
    vsdd_err e = {VSD_E_INTERNAL, ""};
    int fatal = 0;
    cJSON *o;
    if (!cJSON_IsString(hash) || vsd_hash_kind_of(hash->valuestring) == VSD_HASH_NONE) {
        vsdd_send_error(c, id, cJSON_IsString(hash) ? VSD_E_BAD_HASH : VSD_E_BAD_REQUEST,
                        "PUT.hash: expected 32 (xxh3-128) or 64 (sha256) lowercase hex digits", NULL);
        return vsd_proto_skip(c->fd, bin_len, FRAME_TIMEOUT_MS) ? -1 : 0;
    }
    if (vsdd_cache_put_blob(d->cache, c->fd, hash->valuestring, bin_len, &e, &fatal)) {
        vsdd_send_error(c, id, e.code, e.msg, NULL);
        return fatal ? -1 : 0;
    }
    vsdd_count(d->counters, VSDD_COUNT_BLOBS, 1);
    vsdd_count(d->counters, VSDD_COUNT_BLOB_BYTES, bin_len);
    vsdd_log(VSDD_LOG_DEBUG, "conn %u: blob %s stored (%llu bytes)", c->id, hash->valuestring,
             (unsigned long long)bin_len);
    o = cJSON_CreateObject();
    if (cJSON_IsNumber(id)) cJSON_AddNumberToObject(o, "id", id->valuedouble);
    cJSON_AddStringToObject(o, "hash", hash->valuestring);
    cJSON_AddNumberToObject(o, "bytes", (double)bin_len);
    return vsdd_send(c, VSD_MSG_PUT, o, NULL, 0);
}

static void on_render(vsdd_daemon *d, vsdd_conn *c, cJSON *msg, const cJSON *id)
{
    const cJSON *scene = cJSON_GetObjectItemCaseSensitive(msg, "scene");
    int position = 0, rc;
    double idv;
    char text[256];
    if (!cJSON_IsNumber(id)) {
        vsdd_send_error(c, id, VSD_E_BAD_REQUEST, "RENDER.id: required (a number the client chooses)", NULL);
        cJSON_Delete(msg);
        return;
    }
    if (!cJSON_IsObject(scene) && !cJSON_IsString(scene)) {
        vsdd_send_error(c, id, VSD_E_BAD_REQUEST, "RENDER.scene: expected a scene object (or its JSON text)", NULL);
        cJSON_Delete(msg);
        return;
    }
    idv = id->valuedouble; /* `id` lives in msg, which the submit consumes */
    rc = vsdd_job_submit(d->jobs, c, idv, msg, &position);
    if (rc == -1) {
        snprintf(text, sizeof text, "the job queue is full (%d waiting); retry later", d->cfg.queue_max);
        vsdd_send_error_id(c, idv, 1, VSD_E_BUSY, text, NULL);
    } else if (rc == -2) {
        vsdd_send_error_id(c, idv, 1, VSD_E_SHUTDOWN, "the daemon is shutting down", NULL);
    } else if (rc == -3) {
        vsdd_send_error_id(c, idv, 1, VSD_E_BAD_REQUEST,
                           "RENDER.id: a job with this id is already queued or running on this connection", NULL);
    }
}

static void on_cancel(vsdd_daemon *d, vsdd_conn *c, const cJSON *msg, const cJSON *id)
{
    const cJSON *job = cJSON_GetObjectItemCaseSensitive(msg, "job");
    cJSON *o;
    int found;
    if (!cJSON_IsNumber(job)) {
        vsdd_send_error(c, id, VSD_E_BAD_REQUEST, "CANCEL.job: expected the id of a RENDER", NULL);
        return;
    }
    found = vsdd_job_cancel(d->jobs, c, job->valuedouble);
    o = cJSON_CreateObject();
    if (cJSON_IsNumber(id)) cJSON_AddNumberToObject(o, "id", id->valuedouble);
    cJSON_AddNumberToObject(o, "job", job->valuedouble);
    cJSON_AddBoolToObject(o, "found", found);
    vsdd_send(c, VSD_MSG_CANCEL, o, NULL, 0);
}

static void on_stats(vsdd_daemon *d, vsdd_conn *c, const cJSON *id)
{
    cJSON *o = cJSON_CreateObject(), *q, *j;
    uint64_t n[VSDD_COUNT_KINDS];
    int queued, running;
    if (cJSON_IsNumber(id)) cJSON_AddNumberToObject(o, "id", id->valuedouble);
    cJSON_AddStringToObject(o, "server_version", vsd_version());
    cJSON_AddNumberToObject(o, "version", VSD_PROTO_VERSION);
    cJSON_AddNumberToObject(o, "uptime_seconds", vsd_clock_seconds() - d->start_time);
    vsdd_jobs_counts(d->jobs, &queued, &running);
    q = cJSON_AddObjectToObject(o, "queue");
    cJSON_AddNumberToObject(q, "queued", queued);
    cJSON_AddNumberToObject(q, "running", running);
    cJSON_AddNumberToObject(q, "max", d->cfg.queue_max);
    cJSON_AddNumberToObject(q, "workers", d->cfg.workers);
    j = cJSON_AddObjectToObject(o, "jobs");
    vsdd_counters_get(d->counters, n);
    cJSON_AddNumberToObject(j, "done", (double)n[VSDD_COUNT_DONE]);
    cJSON_AddNumberToObject(j, "failed", (double)n[VSDD_COUNT_FAILED]);
    cJSON_AddNumberToObject(j, "cancelled", (double)n[VSDD_COUNT_CANCELLED]);
    cJSON_AddNumberToObject(j, "busy", (double)n[VSDD_COUNT_BUSY]);
    cJSON_AddNumberToObject(o, "connections", vsdd_conns_count(d->conns));
    cJSON_AddNumberToObject(o, "blobs_received", (double)n[VSDD_COUNT_BLOBS]);
    cJSON_AddNumberToObject(o, "blob_bytes_received", (double)n[VSDD_COUNT_BLOB_BYTES]);
    cJSON_AddItemToObject(o, "cache", vsdd_cache_stats(d->cache));
    vsdd_send(c, VSD_MSG_STATS, o, NULL, 0);
}

/* One frame. Returns 0 to go on, -1 to close. */
static int handle_frame(vsdd_daemon *d, vsdd_conn *c)
{
    unsigned char hdr[VSD_PROTO_HEADER_SIZE];
    vsd_frame_header h;
    char *text = NULL, msgbuf[256];
    cJSON *msg = NULL;
    const cJSON *id;
    int r = vsd_proto_read_full(c->fd, hdr, 1, -1);
    if (r) return -1; /* EOF or error: the peer is gone */
    r = vsd_proto_read_full(c->fd, hdr + 1, sizeof hdr - 1, FRAME_TIMEOUT_MS);
    if (r) {
        vsdd_send_error(c, NULL, VSD_E_BAD_FRAME, "truncated frame header", NULL);
        return -1;
    }
    if (vsd_proto_unpack_header(hdr, &h)) {
        vsdd_send_error(c, NULL, VSD_E_BAD_FRAME, "bad magic (expected \"VSDP\"): not a vsd protocol frame", NULL);
        return -1;
    }
    if (h.version != VSD_PROTO_VERSION) {
        cJSON *x = cJSON_CreateObject();
        cJSON_AddItemToObject(x, "versions", cJSON_CreateIntArray((int[]){VSD_PROTO_VERSION}, 1));
        snprintf(msgbuf, sizeof msgbuf, "frame version %u: this daemon speaks protocol version 1", h.version);
        vsdd_send_error(c, NULL, VSD_E_VERSION, msgbuf, x);
        return -1;
    }
    if (h.json_len > d->cfg.max_json || h.bin_len > d->cfg.max_message) {
        snprintf(msgbuf, sizeof msgbuf, "frame too large (JSON %u bytes, binary %llu bytes; limits %u and %llu)",
                 h.json_len, (unsigned long long)h.bin_len, d->cfg.max_json,
                 (unsigned long long)d->cfg.max_message);
        vsdd_send_error(c, NULL, VSD_E_TOO_LARGE, msgbuf, NULL);
        return -1;
    }
    if (h.bin_len && h.type != VSD_MSG_PUT) {
        vsdd_send_error(c, NULL, VSD_E_BAD_REQUEST, "only PUT carries a binary part", NULL);
        return -1;
    }
    text = malloc((size_t)h.json_len + 1);
    if (!text) {
        vsdd_send_error(c, NULL, VSD_E_INTERNAL, "out of memory", NULL);
        return -1;
    }
    if (h.json_len && vsd_proto_read_full(c->fd, text, h.json_len, FRAME_TIMEOUT_MS)) {
        free(text);
        vsdd_send_error(c, NULL, VSD_E_BAD_FRAME, "truncated frame (JSON part)", NULL);
        return -1;
    }
    text[h.json_len] = '\0';
    msg = cJSON_ParseWithLength(text, h.json_len);
    free(text);
    if (!msg || !cJSON_IsObject(msg)) {
        cJSON_Delete(msg);
        vsdd_send_error(c, NULL, VSD_E_BAD_JSON, "the JSON part is not a JSON object", NULL);
        return vsd_proto_skip(c->fd, h.bin_len, FRAME_TIMEOUT_MS) ? -1 : 0;
    }
    id = cJSON_GetObjectItemCaseSensitive(msg, "id");
    if (id && !cJSON_IsNumber(id) && !cJSON_IsNull(id)) {
        cJSON_Delete(msg);
        vsdd_send_error(c, NULL, VSD_E_BAD_REQUEST, "id: expected a number", NULL);
        return vsd_proto_skip(c->fd, h.bin_len, FRAME_TIMEOUT_MS) ? -1 : 0;
    }
    vsdd_log(VSDD_LOG_DEBUG, "conn %u: %s (%u + %llu bytes)", c->id, vsd_msg_name(h.type) ? vsd_msg_name(h.type) : "?",
             h.json_len, (unsigned long long)h.bin_len);
    if (!vsd_msg_name(h.type) || h.type == VSD_MSG_PROGRESS || h.type == VSD_MSG_RESULT || h.type == VSD_MSG_ERROR) {
        snprintf(msgbuf, sizeof msgbuf, "message type %u is not a request this daemon takes", h.type);
        vsdd_send_error(c, id, VSD_E_UNKNOWN_TYPE, msgbuf, NULL);
        cJSON_Delete(msg);
        return 0;
    }
    if (!c->hello_done && h.type != VSD_MSG_HELLO) {
        vsdd_send_error(c, id, VSD_E_HELLO_REQUIRED, "send HELLO first", NULL);
        cJSON_Delete(msg);
        return c->is_tcp ? -1 : vsd_proto_skip(c->fd, h.bin_len, FRAME_TIMEOUT_MS) ? -1 : 0;
    }
    r = 0;
    switch (h.type) {
    case VSD_MSG_HELLO: r = on_hello(d, c, msg, id); break;
    case VSD_MSG_HAS: on_has(d, c, msg, id); break;
    case VSD_MSG_PUT: r = on_put(d, c, msg, id, h.bin_len); break;
    case VSD_MSG_RENDER: on_render(d, c, msg, id); msg = NULL; break;
    case VSD_MSG_CANCEL: on_cancel(d, c, msg, id); break;
    case VSD_MSG_STATS: on_stats(d, c, id); break;
    case VSD_MSG_BYE: {
        cJSON *o = cJSON_CreateObject();
        if (cJSON_IsNumber(id)) cJSON_AddNumberToObject(o, "id", id->valuedouble);
        vsdd_send(c, VSD_MSG_BYE, o, NULL, 0);
        r = -1;
        break;
    }
    }
    cJSON_Delete(msg);
    return r;
}

typedef struct reader {
    vsdd_daemon *d;
    vsdd_conn *c;
} reader;

static void *reader_main(void *arg)
{
    reader *rd = arg;
    vsdd_daemon *d = rd->d;
    vsdd_conn *c = rd->c;
    free(rd);
    while (!vsdd_out_closed(c) && handle_frame(d, c) == 0) {}
    vsdd_log(VSDD_LOG_INFO, "conn %u: closed", c->id);
    vsdd_out_close(c);
    vsdd_jobs_cancel_conn(d->jobs, c);
    vsdd_conns_reader_done(d->conns, c);
    return NULL;
}

void vsdd_conn_start(vsdd_daemon *d, int fd, int is_tcp, const char *peer)
{
    vsdd_conn *c;
    reader *rd;
    pthread_t t;
    pthread_attr_t attr;
    struct timeval tv = {30, 0};
    int stopping;
    /* a client that stops reading cannot block a worker for longer than this */
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    c = vsdd_conn_new(fd, is_tcp, peer);
    if (!c) return;
    stopping = vsdd_jobs_stopping(d->jobs);
    if (vsdd_conns_add(d->conns, c, stopping ? 0 : d->cfg.max_connections)) {
        vsdd_send_error(c, NULL, stopping ? VSD_E_SHUTDOWN : VSD_E_BUSY,
                        stopping ? "the daemon is shutting down" : "too many connections; retry later", NULL);
        vsdd_conn_discard(c);
        return;
    }
    vsdd_log(VSDD_LOG_INFO, "conn %u: accepted (%s)", c->id, peer);
    rd = malloc(sizeof *rd);
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    if (rd) {
        rd->d = d;
        rd->c = c;
    }
    if (!rd || pthread_create(&t, &attr, reader_main, rd) != 0) {
        vsdd_log(VSDD_LOG_ERROR, "conn %u: cannot start a thread", c->id);
        free(rd);
        vsdd_conns_reader_done(d->conns, c);
    }
    pthread_attr_destroy(&attr);
}

void vsdd_conn_stop_all(vsdd_daemon *d)
{
    int k = 0, m;
    vsdd_conn **list = vsdd_conns_hold_all(d->conns, &k);
    for (m = 0; m < k; m++) {
        vsdd_send_error_id(list[m], 0, 0, VSD_E_SHUTDOWN, "the daemon is shutting down", NULL);
        vsdd_out_close(list[m]); /* wakes its reader */
    }
    for (m = 0; m < k; m++) vsdd_conn_release(d->conns, list[m]);
    free(list);
    vsdd_conns_wait_readers(d->conns, 5);
}
