/* vsd_proto.h — protocol v1 of the render daemon (docs/protocol.md): frame header,
 * message types, stable error codes, blob hashes, and blocking socket I/O helpers.
 * Shared by the daemon (service/daemon), the C client (service/client) and the tests.
 * Nothing here allocates except vsd_proto_read_json (caller frees with free()). */
#ifndef VSD_PROTO_H
#define VSD_PROTO_H
#include <stddef.h>
#include <stdint.h>
#ifdef __cplusplus
extern "C" {
#endif

#define VSD_PROTO_VERSION 1
#define VSD_PROTO_MAGIC "VSDP"
#define VSD_PROTO_HEADER_SIZE 20

/* Message types (header bytes 6..7). Replies use the request's type, except RENDER, which
 * is answered by PROGRESS* then RESULT or ERROR. */
typedef enum vsd_msg_type {
    VSD_MSG_HELLO = 1,
    VSD_MSG_HAS = 2,
    VSD_MSG_PUT = 3,
    VSD_MSG_RENDER = 4,
    VSD_MSG_PROGRESS = 5,
    VSD_MSG_RESULT = 6,
    VSD_MSG_ERROR = 7,
    VSD_MSG_CANCEL = 8,
    VSD_MSG_STATS = 9,
    VSD_MSG_BYE = 10
} vsd_msg_type;

/* "HELLO", ... or NULL for an unknown type. */
const char *vsd_msg_name(unsigned type);

typedef struct vsd_frame_header {
    uint16_t version;
    uint16_t type;
    uint32_t json_len;
    uint64_t bin_len;
} vsd_frame_header;

/* 20 bytes, big-endian: "VSDP", u16 version, u16 type, u32 json length, u64 binary length. */
void vsd_proto_pack_header(const vsd_frame_header *h, unsigned char out[VSD_PROTO_HEADER_SIZE]);
/* 0 = ok, -1 = bad magic. Lengths and version are checked by the caller against its limits. */
int vsd_proto_unpack_header(const unsigned char in[VSD_PROTO_HEADER_SIZE], vsd_frame_header *h);

/* Stable error codes sent in ERROR.code (docs/protocol.md lists when each is sent). */
#define VSD_E_BAD_FRAME       "bad_frame"        /* bad magic / truncated header: connection closed */
#define VSD_E_VERSION         "unsupported_version"
#define VSD_E_TOO_LARGE       "too_large"        /* a length above the daemon's limits: connection closed */
#define VSD_E_BAD_JSON        "bad_json"
#define VSD_E_BAD_REQUEST     "bad_request"      /* a field missing or of the wrong type */
#define VSD_E_UNKNOWN_TYPE    "unknown_type"
#define VSD_E_HELLO_REQUIRED  "hello_required"
#define VSD_E_AUTH            "auth"             /* TCP token missing or wrong: connection closed */
#define VSD_E_BUSY            "busy"             /* queue full / too many connections: retry later */
#define VSD_E_MISSING_BLOB    "missing_blob"     /* RENDER names blobs the daemon lacks ("missing") */
#define VSD_E_HASH_MISMATCH   "hash_mismatch"
#define VSD_E_BAD_HASH        "bad_hash"         /* not a valid hash string */
#define VSD_E_PATH_DENIED     "path_denied"
#define VSD_E_INVALID_SCENE   "invalid_scene"    /* the scene parser's error ("status" has vsd_status_str) */
#define VSD_E_INPUT           "bad_input"        /* a VDB / map that cannot be read */
#define VSD_E_LIMIT           "limit"            /* resolution / voxels / blob size above a limit */
#define VSD_E_CACHE_FULL      "cache_full"       /* everything in the cache is in use: retry later */
#define VSD_E_CANCELLED       "cancelled"
#define VSD_E_TIMEOUT         "timeout"          /* the job ran past max_job_seconds */
#define VSD_E_RENDER_FAILED   "render_failed"
#define VSD_E_SHUTDOWN        "shutdown"
#define VSD_E_INTERNAL        "internal"

/* ---- blob hashes -------------------------------------------------------------------
 * A hash is lowercase hex: 32 digits = XXH3-128 (canonical, big-endian bytes, as
 * `xxhsum -H2` prints), 64 digits = SHA-256 (for clients with only hashlib). */
typedef enum vsd_hash_kind { VSD_HASH_NONE = 0, VSD_HASH_XXH3_128 = 1, VSD_HASH_SHA256 = 2 } vsd_hash_kind;
#define VSD_HASH_HEX_MAX 65

vsd_hash_kind vsd_hash_kind_of(const char *hex);      /* NONE when not a valid hash string */
const char *vsd_hash_kind_name(vsd_hash_kind k);      /* "xxh3-128", "sha256" */

typedef struct vsd_hasher vsd_hasher;
vsd_hasher *vsd_hasher_new(vsd_hash_kind kind);       /* NULL on bad kind / no memory */
void vsd_hasher_update(vsd_hasher *h, const void *data, size_t len);
void vsd_hasher_final(vsd_hasher *h, char out[VSD_HASH_HEX_MAX]); /* and frees h */
void vsd_hash_buffer(vsd_hash_kind kind, const void *data, size_t len, char out[VSD_HASH_HEX_MAX]);
/* 0 ok, -1 I/O error (message in err). */
int vsd_hash_file(vsd_hash_kind kind, const char *path, char out[VSD_HASH_HEX_MAX], uint64_t *size,
                  char *err, size_t errlen);

/* ---- blocking I/O ------------------------------------------------------------------- */
/* Read exactly n bytes. timeout_ms < 0 waits forever. Returns 0 ok, 1 clean EOF before the
 * first byte, -1 error / EOF mid-way, -2 timeout. */
int vsd_proto_read_full(int fd, void *buf, size_t n, int timeout_ms);
/* Write all bytes (MSG_NOSIGNAL on sockets). 0 ok, -1 error. */
int vsd_proto_write_full(int fd, const void *buf, size_t n);
/* Read and discard n bytes. */
int vsd_proto_skip(int fd, uint64_t n, int timeout_ms);
/* Header + JSON text + optional binary, in one call (caller serialises writers). */
int vsd_proto_send(int fd, unsigned type, const char *json, size_t json_len, const void *bin, size_t bin_len);

#ifdef __cplusplus
}
#endif
#endif
