#include "sha256.h"

void vsd_sha256_init(vsd_sha256 *s) { sha256_init(&s->ctx); }

void vsd_sha256_update(vsd_sha256 *s, const void *data, size_t len)
{
    sha256_update(&s->ctx, len, (const uint8_t *)data);
}

void vsd_sha256_final(vsd_sha256 *s, unsigned char out[32])
{
    sha256_digest(&s->ctx, SHA256_DIGEST_SIZE, out);
}
