/* sha256.h — SHA-256 for blob names from clients that only have hashlib (Blender's Python),
 * a thin wrapper over GNU Nettle so the rest of the service does not depend on its API. */
#ifndef VSD_SHA256_H
#define VSD_SHA256_H
#include <stddef.h>
#include <nettle/sha2.h>

typedef struct vsd_sha256 {
    struct sha256_ctx ctx;
} vsd_sha256;

void vsd_sha256_init(vsd_sha256 *s);
void vsd_sha256_update(vsd_sha256 *s, const void *data, size_t len);
void vsd_sha256_final(vsd_sha256 *s, unsigned char out[32]);
#endif
