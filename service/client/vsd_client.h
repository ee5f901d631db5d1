/* vsd_client.h — C client of the render daemon (protocol v1, docs/protocol.md).
 *
 * One connection = one vsdc; calls are synchronous and not thread-safe on one vsdc (use one
 * connection per thread). Functions return 0 on success or a vsdc_status; `err` gets a
 * message. When the daemon answered with ERROR, the status is VSDC_ERR_SERVER and
 * vsdc_error_code() gives its stable code ("busy", "missing_blob", ...).
 * Ownership: strings and buffers returned to the caller are malloc'd; free them with
 * free() or vsdc_result_free(). */
#ifndef VSD_CLIENT_H
#define VSD_CLIENT_H
#include <stddef.h>
#include <stdint.h>
#ifdef __cplusplus
extern "C" {
#endif

typedef enum vsdc_status {
    VSDC_OK = 0,
    VSDC_ERR_CONNECT,    /* no daemon at that address */
    VSDC_ERR_IO,         /* the connection broke */
    VSDC_ERR_PROTOCOL,   /* the daemon sent something this client cannot read */
    VSDC_ERR_SERVER,     /* the daemon answered ERROR: see vsdc_error_code() */
    VSDC_ERR_LOCAL       /* a local file could not be read, or no memory */
} vsdc_status;

typedef struct vsdc vsdc;

/* The default socket: $XDG_RUNTIME_DIR/vsd.sock, else /tmp/vsd-$UID.sock. */
void vsdc_default_socket(char *out, size_t len);

/* address: NULL or "" = the default socket; "unix:PATH" or anything containing '/' = a
 * Unix socket; "HOST:PORT" = TCP (token required). Connects and performs HELLO. */
int vsdc_connect(const char *address, const char *token, vsdc **out, char *err, size_t errlen);
void vsdc_close(vsdc *c);            /* BYE, then close; NULL is fine */

const char *vsdc_server_info(const vsdc *c);   /* the HELLO reply, JSON text */
const char *vsdc_error_code(const vsdc *c);    /* code of the last ERROR, "" if none */
/* The last ERROR as JSON text, with its extra fields (missing_blob's "missing": the hashes
 * to PUT), or NULL when the last call got none. Valid until the next call on c. */
const char *vsdc_error_json(const vsdc *c);
int vsdc_fd(const vsdc *c);
uint64_t vsdc_bytes_uploaded(const vsdc *c);   /* blob bytes sent by PUT on this connection */

/* Which of `hashes` the daemon lacks: missing[i] = 1 / 0. */
int vsdc_has(vsdc *c, const char *const *hashes, int n, int *missing, char *err, size_t errlen);
int vsdc_put(vsdc *c, const char *hash, const void *data, size_t len, char *err, size_t errlen);
/* Hash a local file (XXH3-128) and PUT it unless the daemon has it; blob_name gets
 * "blob:<hash>". `sent` (may be NULL) gets the bytes uploaded (0 when it was cached). */
int vsdc_upload_file(vsdc *c, const char *path, char *blob_name, size_t len, uint64_t *sent, char *err,
                     size_t errlen);

typedef void (*vsdc_progress_fn)(void *user, const char *stage, float fraction);

typedef struct vsdc_render_request {
    const char *scene_json;          /* scene file v1 text; files as blob:<hash> (or allowed paths) */
    const char *const *overrides;    /* "key.path=value", applied by the daemon before validation */
    int override_count;
    int frame, has_frame;            /* default: the scene's frames.start */
    int preview;                     /* also return the preview PNG (scene's output.view) */
    vsdc_progress_fn progress;       /* may be NULL */
    void *user;
    volatile int *cancel;            /* set non-zero to send CANCEL; may be NULL */
} vsdc_render_request;

typedef struct vsdc_result {
    unsigned char *exr;              /* the multilayer EXR file's bytes */
    size_t exr_len;
    unsigned char *png;              /* preview PNG bytes or NULL */
    size_t png_len;
    char *json;                      /* the RESULT message: timings, cache hits, samples, ... */
} vsdc_result;

int vsdc_render(vsdc *c, const vsdc_render_request *rq, vsdc_result *res, char *err, size_t errlen);
void vsdc_result_free(vsdc_result *r);

/* STATS reply as JSON text (free()). */
int vsdc_stats(vsdc *c, char **json, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
