/* crm_fit_cache.c — on-disk cache of RBF fits (format in crm_fit_cache.h). Loading trusts
 * nothing in the file: the size must match the count exactly and the checksum must match
 * before any value is used. */
#define _POSIX_C_SOURCE 200809L
#include "crm_fit_cache.h"
#include "src/common/clock.h"
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#define MAGIC "VSDCRMFT"
#define KEY_FIELD 64
#define HEAD_SIZE (8 + 4 + 4 + KEY_FIELD + 8)
#define RBF_SIZE 20
#define MAX_COUNT 1000000
/* Bump when the fit's algorithm changes its results: old cache files then miss. */
#define FIT_ALGORITHM "vsd-crm-fit/1"

/* ------------------------------------------------------------ little-endian packing */

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static uint32_t get_u32(const unsigned char *p)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= (uint32_t)p[i] << (8 * i);
    return v;
}
static uint64_t get_u64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}
static void put_f32(unsigned char *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    put_u32(p, v);
}
static float get_f32(const unsigned char *p)
{
    uint32_t v = get_u32(p);
    float f;
    memcpy(&f, &v, 4);
    return f;
}

/* ------------------------------------------------------------ key */

static void hash_u32(XXH3_state_t *h, uint32_t v)
{
    unsigned char b[4];
    put_u32(b, v);
    XXH3_128bits_update(h, b, 4);
}
static void hash_f32(XXH3_state_t *h, float f)
{
    unsigned char b[4];
    put_f32(b, f);
    XXH3_128bits_update(h, b, 4);
}

vsd_status vsd_crm_fit_cache_key(const vsd_crm_dense *d, const vsd_crm_fit_options *o,
                                 const vsd_crm_rbfs *previous, double first_rel_error, char key[65])
{
    if (key) key[0] = '\0';
    if (!d || !d->d || !o || !key || d->nx <= 0 || d->ny <= 0 || d->nz <= 0)
        return VSD_ERR_INVALID;
    if (previous && (previous->count < 0 || (previous->count > 0 && !previous->rbf)))
        return VSD_ERR_INVALID;
    XXH3_state_t *h = XXH3_createState();
    if (!h) return VSD_ERR_NOMEM;
    XXH3_128bits_reset(h);
    XXH3_128bits_update(h, FIT_ALGORITHM, sizeof FIT_ALGORITHM);
    hash_u32(h, (uint32_t)d->nx);
    hash_u32(h, (uint32_t)d->ny);
    hash_u32(h, (uint32_t)d->nz);
    /* Density in host byte order: every platform vsd builds on is little-endian. */
    XXH3_128bits_update(h, d->d, sizeof(float) * (size_t)d->nx * d->ny * d->nz);
    /* Every option: the fit is deterministic in all of them. */
    hash_u32(h, (uint32_t)o->rbf_count);
    hash_f32(h, o->radius_min);
    hash_f32(h, o->radius_max);
    hash_f32(h, o->weight_min);
    hash_f32(h, o->weight_max);
    hash_u32(h, (uint32_t)o->teleport_every);
    hash_u32(h, (uint32_t)o->max_iterations);
    hash_u32(h, (uint32_t)o->delete_per_frame);
    hash_u32(h, (uint32_t)o->insert_max);
    hash_f32(h, o->error_ratio);
    hash_u32(h, (uint32_t)vsd_crm_fit_stride(d, o));
    hash_u32(h, o->seed);
    /* A previous set with no RBFs is fitted as a first frame (crm_fit.h), so it keys as one. */
    int coherent = previous && previous->count > 0;
    hash_u32(h, (uint32_t)coherent);
    if (coherent) {
        hash_u32(h, (uint32_t)previous->count);
        for (int l = 0; l < previous->count; l++) {
            const vsd_crm_rbf *b = &previous->rbf[l];
            hash_f32(h, b->c[0]);
            hash_f32(h, b->c[1]);
            hash_f32(h, b->c[2]);
            hash_f32(h, b->r);
            hash_f32(h, b->w);
        }
        unsigned char b[8];
        uint64_t bits;
        memcpy(&bits, &first_rel_error, 8);
        put_u64(b, bits);
        XXH3_128bits_update(h, b, 8);
    }
    XXH128_hash_t v = XXH3_128bits_digest(h);
    XXH3_freeState(h);
    snprintf(key, 65, "%016llx%016llx", (unsigned long long)v.high64, (unsigned long long)v.low64);
    return VSD_OK;
}

/* A key names a file: only hex digits, so it can never leave dir. */
static int key_ok(const char *key)
{
    size_t n = key ? strlen(key) : 0;
    if (n == 0 || n > KEY_FIELD) return 0;
    for (size_t i = 0; i < n; i++)
        if (!((key[i] >= '0' && key[i] <= '9') || (key[i] >= 'a' && key[i] <= 'f'))) return 0;
    return 1;
}

static vsd_status cache_path(const char *dir, const char *key, char *path, size_t len, char *err,
                             size_t errlen)
{
    if (!dir || !*dir) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: no folder given");
    if (!key_ok(key))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: key '%.70s' is not 1-64 hex digits",
                        key ? key : "(null)");
    int n = snprintf(path, len, "%s/%s.crmfit", dir, key);
    if (n < 0 || (size_t)n >= len)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: folder path too long: '%.80s...'", dir);
    return VSD_OK;
}

/* ------------------------------------------------------------ load */

static vsd_status parse(const unsigned char *buf, size_t size, const char *path, const char *key,
                        vsd_crm_rbfs *out, double *rel_error, char *err, size_t errlen)
{
    if (size < HEAD_SIZE + 8 || memcmp(buf, MAGIC, 8) != 0)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: not a crm fit cache file", path);
    uint32_t version = get_u32(buf + 8), count = get_u32(buf + 12);
    if (version != VSD_CRM_FIT_CACHE_VERSION)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: crm fit cache version %u, this build reads %d", path,
                        version, VSD_CRM_FIT_CACHE_VERSION);
    /* The count is checked against the size before it sizes anything. */
    if (count > MAX_COUNT || size != HEAD_SIZE + (size_t)count * RBF_SIZE + 8)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: truncated or padded (%zu bytes for %u RBFs)", path,
                        size, count);
    size_t body = size - 8;
    if (XXH3_64bits(buf, body) != get_u64(buf + body))
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: checksum mismatch (corrupt file)", path);
    char fkey[KEY_FIELD + 1];
    memcpy(fkey, buf + 16, KEY_FIELD);
    fkey[KEY_FIELD] = '\0';
    if (strcmp(fkey, key) != 0)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: holds the fit of another key", path);
    uint64_t bits = get_u64(buf + 16 + KEY_FIELD);
    double rel;
    memcpy(&rel, &bits, 8);
    if (!(rel >= 0.0) || !isfinite(rel))
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: invalid relative error", path);
    vsd_crm_rbf *r = count ? malloc(sizeof(vsd_crm_rbf) * count) : NULL;
    if (count && !r) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: out of memory for %u RBFs", path, count);
    for (uint32_t l = 0; l < count; l++) {
        const unsigned char *p = buf + HEAD_SIZE + (size_t)l * RBF_SIZE;
        vsd_crm_rbf *b = &r[l];
        b->c[0] = get_f32(p), b->c[1] = get_f32(p + 4), b->c[2] = get_f32(p + 8);
        b->r = get_f32(p + 12), b->w = get_f32(p + 16);
        if (!isfinite(b->c[0]) || !isfinite(b->c[1]) || !isfinite(b->c[2]) || !isfinite(b->w) ||
            !isfinite(b->r) || !(b->r > 0)) {
            free(r);
            return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: RBF %u is invalid", path, l);
        }
    }
    out->rbf = r;
    out->count = (int)count;
    if (rel_error) *rel_error = rel;
    return VSD_OK;
}

vsd_status vsd_crm_fit_cache_load(const char *dir, const char *key, vsd_crm_rbfs *out, double *rel_error,
                                  char *err, size_t errlen)
{
    char path[4096];
    if (!out) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: no output given");
    out->rbf = NULL;
    out->count = 0;
    vsd_status s = cache_path(dir, key, path, sizeof path, err, errlen);
    if (s != VSD_OK) return s;
    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        if (e == ENOENT) return vsd_fail(VSD_ERR_NOT_FOUND, err, errlen, "%s: not in the cache", path);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot open '%s': %s", path, strerror(e));
    }
    struct stat sb;
    if (fstat(fileno(f), &sb) != 0 || !S_ISREG(sb.st_mode)) {
        fclose(f);
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: not a regular file", path);
    }
    size_t size = (size_t)sb.st_size;
    if ((uint64_t)sb.st_size > HEAD_SIZE + (uint64_t)MAX_COUNT * RBF_SIZE + 8) {
        fclose(f);
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: too large for a crm fit cache file", path);
    }
    unsigned char *buf = malloc(size ? size : 1);
    if (!buf) {
        fclose(f);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: out of memory", path);
    }
    size_t got = fread(buf, 1, size, f);
    int failed = ferror(f);
    fclose(f);
    if (failed) s = vsd_fail(VSD_ERR_IO, err, errlen, "cannot read '%s'", path);
    else s = parse(buf, got, path, key, out, rel_error, err, errlen);
    free(buf);
    return s;
}

/* ------------------------------------------------------------ save */

/* mkdir -p dir. */
static vsd_status make_dirs(const char *dir, char *err, size_t errlen)
{
    char buf[4096];
    if (strlen(dir) >= sizeof buf)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: folder path too long");
    snprintf(buf, sizeof buf, "%s", dir);
    for (char *p = buf + 1; ; p++) {
        if (*p != '/' && *p != '\0') continue;
        char c = *p;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot create folder: %s", buf, strerror(errno));
        *p = c;
        if (c == '\0') break;
    }
    return VSD_OK;
}

static int write_all(int fd, const unsigned char *p, size_t n)
{
    while (n > 0) { /* bounded: every pass writes >= 1 byte or fails */
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

vsd_status vsd_crm_fit_cache_save(const char *dir, const char *key, const vsd_crm_rbfs *r, double rel_error,
                                  char *err, size_t errlen)
{
    char path[4096], tmp[4200];
    vsd_status s = cache_path(dir, key, path, sizeof path, err, errlen);
    if (s != VSD_OK) return s;
    if (!r || r->count < 0 || r->count > MAX_COUNT || (r->count > 0 && !r->rbf))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: invalid RBF set");
    if (!(rel_error >= 0.0) || !isfinite(rel_error))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit cache: rel_error %g is invalid", rel_error);
    s = make_dirs(dir, err, errlen);
    if (s != VSD_OK) return s;
    size_t size = HEAD_SIZE + (size_t)r->count * RBF_SIZE + 8;
    unsigned char *buf = calloc(size, 1);
    if (!buf) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm fit cache: out of memory");
    memcpy(buf, MAGIC, 8);
    put_u32(buf + 8, VSD_CRM_FIT_CACHE_VERSION);
    put_u32(buf + 12, (uint32_t)r->count);
    memcpy(buf + 16, key, strlen(key)); /* NUL padding from calloc */
    uint64_t bits;
    memcpy(&bits, &rel_error, 8);
    put_u64(buf + 16 + KEY_FIELD, bits);
    for (int l = 0; l < r->count; l++) {
        unsigned char *p = buf + HEAD_SIZE + (size_t)l * RBF_SIZE;
        const vsd_crm_rbf *b = &r->rbf[l];
        put_f32(p, b->c[0]), put_f32(p + 4, b->c[1]), put_f32(p + 8, b->c[2]);
        put_f32(p + 12, b->r), put_f32(p + 16, b->w);
    }
    put_u64(buf + size - 8, XXH3_64bits(buf, size - 8));
    /* pid in the temporary name: two processes filling one cache never share it. */
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) {
        int e = errno;
        free(buf);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write '%s': %s", tmp, strerror(e));
    }
    int bad = write_all(fd, buf, size) != 0 || (fsync(fd) != 0 && errno != EINVAL);
    int e = errno;
    free(buf);
    if (close(fd) != 0 && !bad) bad = 1, e = errno;
    if (!bad && rename(tmp, path) != 0) bad = 1, e = errno;
    if (bad) {
        unlink(tmp);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write '%s': %s", path, strerror(e));
    }
    return VSD_OK;
}

/* ------------------------------------------------------------ load or fit */

vsd_status vsd_crm_fit_cached(const char *dir, const vsd_crm_dense *d, const vsd_crm_fit_options *o,
                              const vsd_crm_rbfs *previous, double first_rel_error, vsd_crm_rbfs *out,
                              vsd_crm_fit_stats *stats, char *err, size_t errlen, int *was_cached)
{
    double t0 = vsd_clock_seconds();
    char key[65];
    if (was_cached) *was_cached = 0;
    if (!dir) return vsd_crm_fit(d, o, previous, first_rel_error, out, stats, err, errlen);
    if (!out) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: no output RBF set given");
    /* Options first: a bad option must be reported as such, not as a cache miss. */
    vsd_status s = vsd_crm_fit_options_check(o, err, errlen);
    if (s != VSD_OK) return s;
    if (vsd_crm_fit_cache_key(d, o, previous, first_rel_error, key) != VSD_OK)
        return vsd_crm_fit(d, o, previous, first_rel_error, out, stats, err, errlen); /* it names the problem */
    double rel = 0.0;
    s = vsd_crm_fit_cache_load(dir, key, out, &rel, err, errlen);
    if (s == VSD_OK) {
        if (stats) {
            memset(stats, 0, sizeof *stats);
            stats->rbf_count = out->count;
            stats->rel_error = rel;
            stats->seconds = vsd_clock_seconds() - t0;
        }
        if (was_cached) *was_cached = 1;
        return VSD_OK;
    }
    if (s != VSD_ERR_NOT_FOUND && s != VSD_ERR_FORMAT) return s; /* unreadable cache: say so */
    vsd_crm_fit_stats st;
    s = vsd_crm_fit(d, o, previous, first_rel_error, out, &st, err, errlen);
    if (s != VSD_OK) return s;
    if (stats) *stats = st;
    return vsd_crm_fit_cache_save(dir, key, out, st.rel_error, err, errlen);
}
