/* The C client: a blocking connection that speaks protocol v1. */
#define _GNU_SOURCE
#include "vsd_client.h"
#include "../protocol/vsd_proto.h"
#include <cjson/cJSON.h>
#include <errno.h>
#include <netdb.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#define CLIENT_MAX_JSON (64u << 20)
#define CLIENT_MAX_BIN (8ull << 30)
#define REPLY_TIMEOUT_MS 120000

struct vsdc {
    int fd;
    double next_id;
    char *hello;
    char code[64];
    char *error_json;              /* the last ERROR message, whole (vsdc_error_json) */
    uint64_t uploaded;
};

static int fail(vsdc *c, int st, char *err, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    if (err && errlen) {
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    (void)c;
    return st;
}

void vsdc_default_socket(char *out, size_t len)
{
    const char *xdg = getenv("XDG_RUNTIME_DIR");
    if (xdg && xdg[0]) snprintf(out, len, "%s/vsd.sock", xdg);
    else snprintf(out, len, "/tmp/vsd-%ld.sock", (long)getuid());
}

static int connect_unix(const char *path, char *err, size_t errlen)
{
    struct sockaddr_un a;
    int fd;
    if (strlen(path) >= sizeof a.sun_path) return fail(NULL, -1, err, errlen, "%s: socket path too long", path);
    fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return fail(NULL, -1, err, errlen, "socket: %s", strerror(errno));
    memset(&a, 0, sizeof a);
    a.sun_family = AF_UNIX;
    memcpy(a.sun_path, path, strlen(path));
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        int e = errno;
        close(fd);
        return fail(NULL, -1, err, errlen, "cannot connect to %s: %s (is `vsd serve` running?)", path, strerror(e));
    }
    return fd;
}

static int connect_tcp(const char *hostport, char *err, size_t errlen)
{
    char host[256];
    const char *colon = strrchr(hostport, ':');
    struct addrinfo hints, *res = NULL, *ai;
    int fd = -1, rc, e = 0;
    if (!colon || (size_t)(colon - hostport) >= sizeof host)
        return fail(NULL, -1, err, errlen, "%s: expected HOST:PORT", hostport);
    snprintf(host, sizeof host, "%.*s", (int)(colon - hostport), hostport);
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    if ((rc = getaddrinfo(host, colon + 1, &hints, &res)) != 0)
        return fail(NULL, -1, err, errlen, "%s: %s", hostport, gai_strerror(rc));
    for (ai = res; ai; ai = ai->ai_next) {
        fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd < 0) continue;
        if (connect(fd, ai->ai_addr, ai->ai_addrlen) == 0) break;
        e = errno;
        close(fd);
        fd = -1;
    }
    freeaddrinfo(res);
    if (fd < 0) return fail(NULL, -1, err, errlen, "cannot connect to %s: %s", hostport, strerror(e));
    return fd;
}

static int send_json(vsdc *c, unsigned type, cJSON *o, const void *bin, size_t bin_len, char *err, size_t errlen)
{
    char *text = cJSON_PrintUnformatted(o);
    int rc;
    cJSON_Delete(o);
    if (!text) return fail(c, VSDC_ERR_LOCAL, err, errlen, "out of memory");
    rc = vsd_proto_send(c->fd, type, text, strlen(text), bin, bin_len);
    free(text);
    return rc ? fail(c, VSDC_ERR_IO, err, errlen, "sending to the daemon failed: %s", strerror(errno)) : 0;
}

/* Read one frame: JSON parsed into *msg, binary into *bin (malloc'd, may be NULL). */
static int recv_frame(vsdc *c, int timeout_ms, unsigned *type, cJSON **msg, unsigned char **bin, uint64_t *bin_len,
                      char *err, size_t errlen)
{
    unsigned char hdr[VSD_PROTO_HEADER_SIZE];
    vsd_frame_header h;
    char *text;
    int r;
    *msg = NULL;
    if (bin) *bin = NULL;
    if (bin_len) *bin_len = 0;
    r = vsd_proto_read_full(c->fd, hdr, sizeof hdr, timeout_ms);
    if (r == -2) return fail(c, VSDC_ERR_IO, err, errlen, "the daemon did not answer in time");
    if (r) return fail(c, VSDC_ERR_IO, err, errlen, "the daemon closed the connection");
    if (vsd_proto_unpack_header(hdr, &h) || h.version != VSD_PROTO_VERSION || h.json_len > CLIENT_MAX_JSON ||
        h.bin_len > CLIENT_MAX_BIN)
        return fail(c, VSDC_ERR_PROTOCOL, err, errlen, "the daemon sent an unreadable frame");
    text = malloc((size_t)h.json_len + 1);
    if (!text) return fail(c, VSDC_ERR_LOCAL, err, errlen, "out of memory");
    if (vsd_proto_read_full(c->fd, text, h.json_len, REPLY_TIMEOUT_MS)) {
        free(text);
        return fail(c, VSDC_ERR_IO, err, errlen, "the connection broke mid-frame");
    }
    text[h.json_len] = '\0';
    *msg = cJSON_ParseWithLength(text, h.json_len);
    free(text);
    if (!*msg || !cJSON_IsObject(*msg)) {
        cJSON_Delete(*msg);
        *msg = NULL;
        return fail(c, VSDC_ERR_PROTOCOL, err, errlen, "the daemon sent invalid JSON");
    }
    if (h.bin_len) {
        unsigned char *b = bin ? malloc((size_t)h.bin_len) : NULL;
        int rr;
        if (bin && !b) {
            cJSON_Delete(*msg);
            *msg = NULL;
            return fail(c, VSDC_ERR_LOCAL, err, errlen, "out of memory for %llu bytes", (unsigned long long)h.bin_len);
        }
        rr = b ? vsd_proto_read_full(c->fd, b, (size_t)h.bin_len, REPLY_TIMEOUT_MS)
               : vsd_proto_skip(c->fd, h.bin_len, REPLY_TIMEOUT_MS);
        if (rr) {
            free(b);
            cJSON_Delete(*msg);
            *msg = NULL;
            return fail(c, VSDC_ERR_IO, err, errlen, "the connection broke mid-frame");
        }
        if (bin) *bin = b;
        if (bin_len) *bin_len = h.bin_len;
    }
    *type = h.type;
    return 0;
}

static double msg_id(const cJSON *m, int *has)
{
    const cJSON *id = cJSON_GetObjectItemCaseSensitive(m, "id");
    *has = cJSON_IsNumber(id);
    return *has ? id->valuedouble : 0;
}

/* An ERROR message into c->code and err. */
static int server_error(vsdc *c, const cJSON *m, char *err, size_t errlen)
{
    const cJSON *code = cJSON_GetObjectItemCaseSensitive(m, "code");
    const cJSON *text = cJSON_GetObjectItemCaseSensitive(m, "message");
    snprintf(c->code, sizeof c->code, "%s", cJSON_IsString(code) ? code->valuestring : "unknown");
    free(c->error_json);
    c->error_json = cJSON_PrintUnformatted(m);
    return fail(c, VSDC_ERR_SERVER, err, errlen, "daemon: %s: %s", c->code,
                cJSON_IsString(text) ? text->valuestring : "(no message)");
}

/* Wait for the reply of request `id` of type `want` (or an ERROR about it / about the
 * connection). Other frames (progress of nothing we track) are dropped. */
static int wait_reply(vsdc *c, double id, unsigned want, cJSON **out, char *err, size_t errlen)
{
    for (;;) {
        unsigned type;
        cJSON *m;
        int has, rc = recv_frame(c, REPLY_TIMEOUT_MS, &type, &m, NULL, NULL, err, errlen);
        double mid;
        if (rc) return rc;
        mid = msg_id(m, &has);
        if (type == VSD_MSG_ERROR && (!has || mid == id)) {
            rc = server_error(c, m, err, errlen);
            cJSON_Delete(m);
            return rc;
        }
        if (type == want && has && mid == id) {
            *out = m;
            return 0;
        }
        cJSON_Delete(m);
    }
}

int vsdc_connect(const char *address, const char *token, vsdc **out, char *err, size_t errlen)
{
    char path[512];
    vsdc *c;
    cJSON *o, *reply = NULL;
    int fd, rc;
    *out = NULL;
    if (!address || !address[0]) {
        vsdc_default_socket(path, sizeof path);
        fd = connect_unix(path, err, errlen);
    } else if (strncmp(address, "unix:", 5) == 0) fd = connect_unix(address + 5, err, errlen);
    else if (strchr(address, '/')) fd = connect_unix(address, err, errlen);
    else fd = connect_tcp(address, err, errlen);
    if (fd < 0) return VSDC_ERR_CONNECT;
    c = calloc(1, sizeof *c);
    if (!c) {
        close(fd);
        return fail(NULL, VSDC_ERR_LOCAL, err, errlen, "out of memory");
    }
    c->fd = fd;
    c->next_id = 1;
    o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "id", c->next_id);
    cJSON_AddItemToObject(o, "versions", cJSON_CreateIntArray((int[]){VSD_PROTO_VERSION}, 1));
    cJSON_AddStringToObject(o, "client", "vsd-c-client");
    if (token) cJSON_AddStringToObject(o, "token", token);
    rc = send_json(c, VSD_MSG_HELLO, o, NULL, 0, err, errlen);
    if (!rc) rc = wait_reply(c, c->next_id++, VSD_MSG_HELLO, &reply, err, errlen);
    if (rc) {
        close(fd);
        free(c->error_json);
        free(c);
        return rc;
    }
    c->hello = cJSON_PrintUnformatted(reply);
    cJSON_Delete(reply);
    *out = c;
    return 0;
}

void vsdc_close(vsdc *c)
{
    if (!c) return;
    {
        cJSON *o = cJSON_CreateObject(), *reply = NULL;
        char err[64];
        cJSON_AddNumberToObject(o, "id", c->next_id);
        if (send_json(c, VSD_MSG_BYE, o, NULL, 0, err, sizeof err) == 0) {
            struct pollfd p = {c->fd, POLLIN, 0};
            if (poll(&p, 1, 1000) > 0 && wait_reply(c, c->next_id, VSD_MSG_BYE, &reply, err, sizeof err) == 0)
                cJSON_Delete(reply);
        }
    }
    close(c->fd);
    free(c->hello);
    free(c->error_json);
    free(c);
}

const char *vsdc_server_info(const vsdc *c) { return c->hello; }
const char *vsdc_error_code(const vsdc *c) { return c->code; }
const char *vsdc_error_json(const vsdc *c) { return c->code[0] && c->error_json ? c->error_json : NULL; }
int vsdc_fd(const vsdc *c) { return c->fd; }
uint64_t vsdc_bytes_uploaded(const vsdc *c) { return c->uploaded; }

int vsdc_has(vsdc *c, const char *const *hashes, int n, int *missing, char *err, size_t errlen)
{
    cJSON *o = cJSON_CreateObject(), *arr = cJSON_AddArrayToObject(o, "hashes"), *reply = NULL;
    const cJSON *miss, *it;
    double id = c->next_id++;
    int i, rc;
    c->code[0] = '\0';
    for (i = 0; i < n; i++) cJSON_AddItemToArray(arr, cJSON_CreateString(hashes[i]));
    cJSON_AddNumberToObject(o, "id", id);
    if ((rc = send_json(c, VSD_MSG_HAS, o, NULL, 0, err, errlen))) return rc;
    if ((rc = wait_reply(c, id, VSD_MSG_HAS, &reply, err, errlen))) return rc;
    miss = cJSON_GetObjectItemCaseSensitive(reply, "missing");
    for (i = 0; i < n; i++) {
        missing[i] = 0;
        cJSON_ArrayForEach(it, miss) if (cJSON_IsString(it) && strcmp(it->valuestring, hashes[i]) == 0) missing[i] = 1;
    }
    cJSON_Delete(reply);
    return 0;
}

int vsdc_put(vsdc *c, const char *hash, const void *data, size_t len, char *err, size_t errlen)
{
    cJSON *o = cJSON_CreateObject(), *reply = NULL;
    double id = c->next_id++;
    int rc;
    c->code[0] = '\0';
    cJSON_AddNumberToObject(o, "id", id);
    cJSON_AddStringToObject(o, "hash", hash);
    if ((rc = send_json(c, VSD_MSG_PUT, o, data, len, err, errlen))) return rc;
    if ((rc = wait_reply(c, id, VSD_MSG_PUT, &reply, err, errlen))) return rc;
    c->uploaded += len;
    cJSON_Delete(reply);
    return 0;
}

static int read_file(const char *path, unsigned char **data, size_t *len, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    long n;
    *data = NULL;
    if (!f) return fail(NULL, VSDC_ERR_LOCAL, err, errlen, "%s: cannot open: %s", path, strerror(errno));
    if (fseek(f, 0, SEEK_END) || (n = ftell(f)) < 0 || fseek(f, 0, SEEK_SET)) {
        fclose(f);
        return fail(NULL, VSDC_ERR_LOCAL, err, errlen, "%s: cannot read", path);
    }
    *data = malloc(n ? (size_t)n : 1);
    if (!*data || fread(*data, 1, (size_t)n, f) != (size_t)n) {
        free(*data);
        *data = NULL;
        fclose(f);
        return fail(NULL, VSDC_ERR_LOCAL, err, errlen, "%s: cannot read", path);
    }
    fclose(f);
    *len = (size_t)n;
    return 0;
}

int vsdc_upload_file(vsdc *c, const char *path, char *blob_name, size_t len, uint64_t *sent, char *err,
                     size_t errlen)
{
    char hash[VSD_HASH_HEX_MAX];
    const char *h1[1];
    int missing = 0, rc;
    if (sent) *sent = 0;
    if (vsd_hash_file(VSD_HASH_XXH3_128, path, hash, NULL, err, errlen)) return VSDC_ERR_LOCAL;
    snprintf(blob_name, len, "blob:%s", hash);
    h1[0] = hash;
    if ((rc = vsdc_has(c, h1, 1, &missing, err, errlen))) return rc;
    if (missing) {
        unsigned char *data = NULL;
        size_t n = 0;
        char hash2[VSD_HASH_HEX_MAX];
        if ((rc = read_file(path, &data, &n, err, errlen))) return rc;
        vsd_hash_buffer(VSD_HASH_XXH3_128, data, n, hash2);
        if (strcmp(hash, hash2) != 0) {
            free(data);
            return fail(c, VSDC_ERR_LOCAL, err, errlen, "%s: the file changed while it was being sent", path);
        }
        rc = vsdc_put(c, hash, data, n, err, errlen);
        free(data);
        if (rc) return rc;
        if (sent) *sent = n;
    }
    return 0;
}

void vsdc_result_free(vsdc_result *r)
{
    if (!r) return;
    free(r->exr);
    free(r->png);
    free(r->json);
    memset(r, 0, sizeof *r);
}

int vsdc_render(vsdc *c, const vsdc_render_request *rq, vsdc_result *res, char *err, size_t errlen)
{
    cJSON *o = cJSON_CreateObject(), *scene;
    double id = c->next_id++;
    int i, rc, cancel_sent = 0;
    memset(res, 0, sizeof *res);
    c->code[0] = '\0';
    scene = cJSON_Parse(rq->scene_json ? rq->scene_json : "");
    if (!scene) {
        cJSON_Delete(o);
        return fail(c, VSDC_ERR_LOCAL, err, errlen, "the scene is not valid JSON");
    }
    cJSON_AddNumberToObject(o, "id", id);
    cJSON_AddItemToObject(o, "scene", scene);
    if (rq->override_count > 0) {
        cJSON *arr = cJSON_AddArrayToObject(o, "overrides");
        for (i = 0; i < rq->override_count; i++) cJSON_AddItemToArray(arr, cJSON_CreateString(rq->overrides[i]));
    }
    if (rq->has_frame) cJSON_AddNumberToObject(o, "frame", rq->frame);
    if (rq->preview) cJSON_AddTrueToObject(o, "preview");
    if ((rc = send_json(c, VSD_MSG_RENDER, o, NULL, 0, err, errlen))) return rc;
    for (;;) {
        struct pollfd p = {c->fd, POLLIN, 0};
        unsigned type;
        cJSON *m;
        unsigned char *bin = NULL;
        uint64_t bin_len = 0;
        int has, pr;
        double mid;
        if (rq->cancel && *rq->cancel && !cancel_sent) {
            cJSON *x = cJSON_CreateObject();
            cJSON_AddNumberToObject(x, "id", c->next_id++);
            cJSON_AddNumberToObject(x, "job", id);
            if ((rc = send_json(c, VSD_MSG_CANCEL, x, NULL, 0, err, errlen))) return rc;
            cancel_sent = 1;
        }
        pr = poll(&p, 1, 100);
        if (pr < 0 && errno != EINTR) return fail(c, VSDC_ERR_IO, err, errlen, "poll: %s", strerror(errno));
        if (pr <= 0) continue;
        if ((rc = recv_frame(c, REPLY_TIMEOUT_MS, &type, &m, &bin, &bin_len, err, errlen))) return rc;
        mid = msg_id(m, &has);
        if (type == VSD_MSG_ERROR && (!has || mid == id)) {
            rc = server_error(c, m, err, errlen);
            cJSON_Delete(m);
            free(bin);
            return rc;
        }
        if (type == VSD_MSG_PROGRESS && has && mid == id) {
            const cJSON *st = cJSON_GetObjectItemCaseSensitive(m, "stage");
            const cJSON *fr = cJSON_GetObjectItemCaseSensitive(m, "fraction");
            if (rq->progress && cJSON_IsString(st) && cJSON_IsNumber(fr))
                rq->progress(rq->user, st->valuestring, (float)fr->valuedouble);
        } else if (type == VSD_MSG_RESULT && has && mid == id) {
            const cJSON *ne = cJSON_GetObjectItemCaseSensitive(m, "exr_bytes");
            const cJSON *np = cJSON_GetObjectItemCaseSensitive(m, "png_bytes");
            double e = cJSON_IsNumber(ne) ? ne->valuedouble : -1, pp = cJSON_IsNumber(np) ? np->valuedouble : 0;
            if (e < 0 || pp < 0 || (uint64_t)e + (uint64_t)pp != bin_len) {
                cJSON_Delete(m);
                free(bin);
                return fail(c, VSDC_ERR_PROTOCOL, err, errlen, "RESULT: part sizes do not add up");
            }
            res->exr_len = (size_t)e;
            res->png_len = (size_t)pp;
            res->exr = bin;
            if (res->png_len) {
                res->png = malloc(res->png_len);
                if (!res->png) {
                    cJSON_Delete(m);
                    vsdc_result_free(res);
                    return fail(c, VSDC_ERR_LOCAL, err, errlen, "out of memory");
                }
                memcpy(res->png, bin + res->exr_len, res->png_len);
            }
            res->json = cJSON_PrintUnformatted(m);
            cJSON_Delete(m);
            return 0;
        }
        cJSON_Delete(m);
        free(bin);
    }
}

int vsdc_stats(vsdc *c, char **json, char *err, size_t errlen)
{
    cJSON *o = cJSON_CreateObject(), *reply = NULL;
    double id = c->next_id++;
    int rc;
    *json = NULL;
    c->code[0] = '\0';
    cJSON_AddNumberToObject(o, "id", id);
    if ((rc = send_json(c, VSD_MSG_STATS, o, NULL, 0, err, errlen))) return rc;
    if ((rc = wait_reply(c, id, VSD_MSG_STATS, &reply, err, errlen))) return rc;
    *json = cJSON_PrintUnformatted(reply);
    cJSON_Delete(reply);
    return 0;
}
