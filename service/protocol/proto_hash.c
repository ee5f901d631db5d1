/* Blob hashes: XXH3-128 (libxxhash) and SHA-256, as lowercase hex. */
#define _POSIX_C_SOURCE 200809L
#include "vsd_proto.h"
#include "sha256.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <xxhash.h>

struct vsd_hasher {
    vsd_hash_kind kind;
    XXH3_state_t *x;
    vsd_sha256 s;
};

vsd_hash_kind vsd_hash_kind_of(const char *hex)
{
    size_t n = 0;
    if (!hex) return VSD_HASH_NONE;
    for (; hex[n]; n++) {
        char c = hex[n];
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return VSD_HASH_NONE;
        if (n > 64) return VSD_HASH_NONE;
    }
    return n == 32 ? VSD_HASH_XXH3_128 : n == 64 ? VSD_HASH_SHA256 : VSD_HASH_NONE;
}

const char *vsd_hash_kind_name(vsd_hash_kind k)
{
    return k == VSD_HASH_XXH3_128 ? "xxh3-128" : k == VSD_HASH_SHA256 ? "sha256" : "none";
}

vsd_hasher *vsd_hasher_new(vsd_hash_kind kind)
{
    vsd_hasher *h;
    if (kind != VSD_HASH_XXH3_128 && kind != VSD_HASH_SHA256) return NULL;
    h = calloc(1, sizeof *h);
    if (!h) return NULL;
    h->kind = kind;
    if (kind == VSD_HASH_XXH3_128) {
        h->x = XXH3_createState();
        if (!h->x) {
            free(h);
            return NULL;
        }
        XXH3_128bits_reset(h->x);
    } else {
        vsd_sha256_init(&h->s);
    }
    return h;
}

void vsd_hasher_update(vsd_hasher *h, const void *data, size_t len)
{
    if (h->kind == VSD_HASH_XXH3_128) XXH3_128bits_update(h->x, data, len);
    else vsd_sha256_update(&h->s, data, len);
}

static void to_hex(const unsigned char *b, size_t n, char *out)
{
    static const char digits[] = "0123456789abcdef";
    size_t i;
    for (i = 0; i < n; i++) {
        out[2 * i] = digits[b[i] >> 4];
        out[2 * i + 1] = digits[b[i] & 15];
    }
    out[2 * n] = '\0';
}

void vsd_hasher_final(vsd_hasher *h, char out[VSD_HASH_HEX_MAX])
{
    if (h->kind == VSD_HASH_XXH3_128) {
        XXH128_canonical_t c;
        XXH128_canonicalFromHash(&c, XXH3_128bits_digest(h->x));
        to_hex(c.digest, sizeof c.digest, out);
        XXH3_freeState(h->x);
    } else {
        unsigned char d[32];
        vsd_sha256_final(&h->s, d);
        to_hex(d, 32, out);
    }
    free(h);
}

void vsd_hash_buffer(vsd_hash_kind kind, const void *data, size_t len, char out[VSD_HASH_HEX_MAX])
{
    if (kind == VSD_HASH_SHA256) {
        vsd_sha256 s;
        unsigned char d[32];
        vsd_sha256_init(&s);
        vsd_sha256_update(&s, data, len);
        vsd_sha256_final(&s, d);
        to_hex(d, 32, out);
    } else {
        XXH128_canonical_t c;
        XXH128_canonicalFromHash(&c, XXH3_128bits(data, len));
        to_hex(c.digest, sizeof c.digest, out);
    }
}

int vsd_hash_file(vsd_hash_kind kind, const char *path, char out[VSD_HASH_HEX_MAX], uint64_t *size,
                  char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    vsd_hasher *h;
    static const size_t chunk = 1 << 20;
    unsigned char *buf;
    uint64_t total = 0;
    size_t n;
    if (!f) {
        if (err && errlen) snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    buf = malloc(chunk);
    h = vsd_hasher_new(kind);
    if (!buf || !h) {
        free(buf);
        if (h) vsd_hasher_final(h, out);
        fclose(f);
        if (err && errlen) snprintf(err, errlen, "out of memory");
        return -1;
    }
    while ((n = fread(buf, 1, chunk, f)) > 0) {
        vsd_hasher_update(h, buf, n);
        total += n;
    }
    vsd_hasher_final(h, out);
    free(buf);
    if (ferror(f)) {
        fclose(f);
        if (err && errlen) snprintf(err, errlen, "%s: read error", path);
        return -1;
    }
    fclose(f);
    if (size) *size = total;
    return 0;
}
