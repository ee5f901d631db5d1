/* sha256.h — SHA-256 (FIPS 180-4), for blob names from clients that only have hashlib. */
#ifndef VSD_SHA256_H
#define VSD_SHA256_H
#include <stddef.h>
#include <stdint.h>

typedef struct vsd_sha256 {
    uint32_t h[8];
    uint64_t len;
    unsigned char buf[64];
    size_t fill;
} vsd_sha256;

void vsd_sha256_init(vsd_sha256 *s);
void vsd_sha256_update(vsd_sha256 *s, const void *data, size_t len);
void vsd_sha256_final(vsd_sha256 *s, unsigned char out[32]);
#endif
