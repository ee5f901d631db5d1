#include "vsd/status.h"
#include <stdarg.h>
#include <stdio.h>

const char *vsd_status_str(vsd_status s)
{
    switch (s) {
    case VSD_OK: return "ok";
    case VSD_ERR_IO: return "io";
    case VSD_ERR_FORMAT: return "format";
    case VSD_ERR_NOT_FOUND: return "not-found";
    case VSD_ERR_TYPE: return "type";
    case VSD_ERR_INVALID: return "invalid";
    case VSD_ERR_UNSUPPORTED: return "unsupported";
    case VSD_ERR_NOMEM: return "no-memory";
    case VSD_ERR_CANCELLED: return "cancelled";
    case VSD_ERR_INTERNAL: return "internal";
    case VSD_ERR_DEVICE: return "device";
    }
    return "unknown";
}

vsd_status vsd_fail(vsd_status s, char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return s;
}
