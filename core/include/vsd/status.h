/* vsd/status.h — error codes shared by every vsd function.
 * Functions return a vsd_status; a human-readable message goes into the caller's `err`
 * buffer (always NUL-terminated, may be NULL) or is kept on the object. Nothing is owned here. */
#ifndef VSD_STATUS_H
#define VSD_STATUS_H
#include <stddef.h>
#ifdef __cplusplus
extern "C" {
#endif

typedef enum vsd_status {
    VSD_OK = 0,
    VSD_ERR_IO,          /* missing, unreadable or unwritable file */
    VSD_ERR_FORMAT,      /* file is not what it claims, truncated, or corrupt */
    VSD_ERR_NOT_FOUND,   /* a named thing (grid, method, key) does not exist */
    VSD_ERR_TYPE,        /* a value has the wrong type (non-float grid, string for number) */
    VSD_ERR_INVALID,     /* a value is out of range or inconsistent */
    VSD_ERR_UNSUPPORTED, /* valid request this build cannot serve (no CUDA, unknown method) */
    VSD_ERR_NOMEM,       /* allocation failed or a request exceeds a memory limit */
    VSD_ERR_CANCELLED,   /* the caller asked to stop */
    VSD_ERR_INTERNAL,    /* a bug: please report */
    VSD_ERR_DEVICE       /* the GPU failed (launch error, lost device); message has CUDA's words */
} vsd_status;

/* Stable short name of a status ("ok", "io", "format", ...). Never NULL. */
const char *vsd_status_str(vsd_status s);

/* printf into err (when err != NULL && errlen > 0) and return s: `return vsd_fail(...)`. */
vsd_status vsd_fail(vsd_status s, char *err, size_t errlen, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

#ifdef __cplusplus
}
#endif
#endif
