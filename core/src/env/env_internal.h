/* Internal to core/src/env: the Radiance RGBE reader behind vsd_env_load. */
#ifndef VSD_ENV_INTERNAL_H
#define VSD_ENV_INTERNAL_H
#include "vsd/status.h"

/* Decode a Radiance .hdr/.pic file into a malloc'd RGB float array (row 0 = top).
 * VSD_ERR_IO (cannot open), VSD_ERR_FORMAT (not RGBE, truncated, corrupt; with the byte
 * offset), VSD_ERR_UNSUPPORTED (XYZE pixels, orientation other than "-Y H +X W"). */
vsd_status vsd_rgbe_read(const char *path, int *w, int *h, float **rgb, char *err, size_t errlen);

#endif
