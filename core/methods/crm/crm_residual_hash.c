/* crm_residual_hash.c — quantising the density residual and building its perfect spatial
 * hash (Zhou et al. 2008 §5.2, Lefebvre & Hoppe 2006 §4). See crm_residual_hash.h for the
 * sizes and growth policy, crm_hash_kernel.h for the lookup this must agree with. */
#include "crm_residual_hash.h"
#include "src/common/clock.h"
#include "src/common/coprime.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The kernel forms the voxel index n in uint32 and the CPU side in int arithmetic elsewhere:
 * keep n below 2^31. */
#define MAX_VOXELS 2147483647ull
/* r^3 bucket ids are uint32 (with one spare value for "no slot"). */
#define MAX_R 1600
#define NO_SLOT 0xffffffffu
/* Offset search steps (one per voxel tested) allowed per voxel stored, per attempt: far above
 * what a build uses (measured on 128^3 residuals: ~2 per voxel when the sizes work, 20-90
 * when they fail, mostly the failing bucket's scan of every free slot), so it only bounds the
 * time of a pathological input. */
#define WORK_PER_KEY 512u

struct vsd_crm_hash {
    uint32_t *occupancy;
    uint32_t *offsets;
    int8_t *table;
    vsd_crm_hash_view view;
    vsd_crm_hash_stats stats;
};

/* ---- small helpers ---- */

/* Smallest c >= 0 with den * c^3 >= num: ceil(cbrt(num / den)) without rounding trouble. */
static int ceil_cbrt_ratio(size_t num, size_t den)
{
    int c = (int)cbrt((double)num / (double)den);
    while ((size_t)c * c * c * den < num) c++;
    while (c > 0 && (size_t)(c - 1) * (c - 1) * (c - 1) * den >= num) c--;
    return c;
}

static uint64_t rng_next(uint64_t *s)
{
    /* xorshift64*: only spreads the search starts; quality needs are modest. */
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return x * 0x2545F4914F6CDD1Dull;
}

static vsd_status check_grid(int nx, int ny, int nz, size_t *n, char *err, size_t errlen)
{
    if (nx <= 0 || ny <= 0 || nz <= 0)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm residual: grid size %d x %d x %d is not positive", nx,
                        ny, nz);
    if ((unsigned long long)nx * (unsigned long long)ny * (unsigned long long)nz > MAX_VOXELS)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm residual: grid %d x %d x %d has more than %llu voxels",
                        nx, ny, nz, MAX_VOXELS);
    *n = (size_t)nx * (size_t)ny * (size_t)nz;
    return VSD_OK;
}

/* ---- quantisation ---- */

/* Validate R (naming the first bad voxel) and return max |R|. */
static vsd_status scan_residual(int nx, int ny, size_t n, const float *residual, float *max_abs, char *err,
                                size_t errlen)
{
    float mx = 0.0f;
    size_t v;
    for (v = 0; v < n; v++) {
        float a = fabsf(residual[v]);
        if (!isfinite(a)) {
            size_t i = v % (size_t)nx, j = (v / (size_t)nx) % (size_t)ny, k = v / ((size_t)nx * (size_t)ny);
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm residual: voxel (%zu, %zu, %zu) is %s", i, j, k,
                            isnan(a) ? "NaN" : "infinite");
        }
        if (a > mx) mx = a;
    }
    *max_abs = mx;
    return VSD_OK;
}

vsd_status vsd_crm_quantise_residual(int nx, int ny, int nz, const float *residual, float quant_step, int8_t *q,
                                     float *step_out, size_t *stored_out, size_t *clamped_out, char *err,
                                     size_t errlen)
{
    size_t n = 0, v, stored = 0, clamped = 0;
    float max_abs = 0.0f, step;
    vsd_status st = check_grid(nx, ny, nz, &n, err, errlen);
    if (st) return st;
    if (!residual || !q) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm residual: NULL residual or output");
    if (!(quant_step >= 0.0f) || !isfinite(quant_step))
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "crm residual: quantisation step %g is not a finite value >= 0 (0 = auto)", (double)quant_step);
    st = scan_residual(nx, ny, n, residual, &max_abs, err, errlen);
    if (st) return st;
    step = quant_step > 0.0f ? quant_step : (max_abs > 0.0f ? max_abs / 127.0f : 1.0f);
    /* max_abs / 127 underflows to 0 only for denormal residuals; then treat them as 0. */
    if (!(step > 0.0f)) step = 1.0f;
    for (v = 0; v < n; v++) {
        /* roundf: half away from zero, independent of the FPU rounding mode. */
        float t = roundf(residual[v] / step);
        if (t > 127.0f || t < -127.0f) {
            t = t > 0.0f ? 127.0f : -127.0f;
            clamped++;
        }
        q[v] = (int8_t)t;
        stored += q[v] != 0;
    }
    if (step_out) *step_out = step;
    if (stored_out) *stored_out = stored;
    if (clamped_out) *clamped_out = clamped;
    return VSD_OK;
}

/* ---- the offset assignment (L&H §4.3) ---- */

/* Scratch of one assignment attempt. h0 coordinates are packed like the offsets (10 bits
 * per axis), since both are < m <= 1024. */
typedef struct attempt {
    int m, r;
    size_t K, m3, r3;
    uint32_t *bucket_start; /* [r3 + 1]: keys of bucket b are bucket_h0[bucket_start[b] ..) */
    uint32_t *bucket_h0;    /* [K] packed h0 of each key, grouped by bucket */
    uint32_t *order;        /* nonempty buckets, largest first */
    uint32_t *free_list;    /* [m3] free H slots, first `nfree` valid */
    uint32_t *free_pos;     /* [m3] index of a slot in free_list, NO_SLOT when taken */
    uint32_t *stamp;        /* [m3] bucket id + 1 that last claimed this h0 (collision test) */
    size_t nfree;
    size_t nonempty;
} attempt;

static void attempt_free(attempt *a)
{
    free(a->bucket_start);
    free(a->bucket_h0);
    free(a->order);
    free(a->free_list);
    free(a->free_pos);
    free(a->stamp);
}

static uint32_t pack3(uint32_t x, uint32_t y, uint32_t z) { return x | y << 10 | z << 20; }

/* Group the keys by offset slot h1 (counting sort) and order the buckets by decreasing size
 * (a second counting sort, on size), as L&H: the big buckets are the hard ones, so they go
 * while H is still empty. */
static vsd_status attempt_buckets(attempt *a, const uint32_t *keys, int nx, int ny)
{
    size_t t, b, maxsize = 0, *count_of_size = NULL;
    uint32_t *fill = NULL, *bucket_of = NULL;
    int m = a->m, r = a->r;
    a->bucket_start = calloc(a->r3 + 1, sizeof *a->bucket_start);
    a->bucket_h0 = malloc(a->K * sizeof *a->bucket_h0);
    bucket_of = malloc(a->K * sizeof *bucket_of);
    if (!a->bucket_start || !a->bucket_h0 || !bucket_of) goto nomem;
    for (t = 0; t < a->K; t++) {
        uint32_t n = keys[t], i = n % (uint32_t)nx, j = (n / (uint32_t)nx) % (uint32_t)ny,
                 k = n / ((uint32_t)nx * (uint32_t)ny);
        bucket_of[t] = ((k % r) * (uint32_t)r + j % r) * (uint32_t)r + i % r;
        a->bucket_start[bucket_of[t] + 1]++;
    }
    for (b = 0; b < a->r3; b++) {
        size_t s = a->bucket_start[b + 1];
        if (s > maxsize) maxsize = s;
        a->nonempty += s > 0;
        a->bucket_start[b + 1] += a->bucket_start[b];
    }
    fill = malloc(a->r3 * sizeof *fill);
    if (!fill) goto nomem;
    memcpy(fill, a->bucket_start, a->r3 * sizeof *fill);
    for (t = 0; t < a->K; t++) {
        uint32_t n = keys[t], i = n % (uint32_t)nx, j = (n / (uint32_t)nx) % (uint32_t)ny,
                 k = n / ((uint32_t)nx * (uint32_t)ny);
        a->bucket_h0[fill[bucket_of[t]]++] = pack3(i % m, j % m, k % m);
    }
    /* Buckets by decreasing size: count per size, then place from the largest down. */
    count_of_size = calloc(maxsize + 2, sizeof *count_of_size);
    a->order = malloc((a->nonempty ? a->nonempty : 1) * sizeof *a->order);
    if (!count_of_size || !a->order) goto nomem;
    for (b = 0; b < a->r3; b++) count_of_size[a->bucket_start[b + 1] - a->bucket_start[b]]++;
    {
        size_t pos = 0, s;
        for (s = maxsize; s >= 1; s--) {
            size_t c = count_of_size[s];
            count_of_size[s] = pos;
            pos += c;
        }
    }
    for (b = 0; b < a->r3; b++) {
        size_t s = a->bucket_start[b + 1] - a->bucket_start[b];
        if (s) a->order[count_of_size[s]++] = (uint32_t)b;
    }
    free(count_of_size);
    free(fill);
    free(bucket_of);
    return VSD_OK;
nomem:
    free(count_of_size);
    free(fill);
    free(bucket_of);
    return VSD_ERR_NOMEM;
}

static void take_slot(attempt *a, uint32_t slot)
{
    uint32_t p = a->free_pos[slot], last = a->free_list[a->nfree - 1];
    a->free_list[p] = last;
    a->free_pos[last] = p;
    a->free_pos[slot] = NO_SLOT;
    a->nfree--;
}

/* H slot of packed h0 `h` shifted by offset (ox, oy, oz). */
static uint32_t shifted_slot(const attempt *a, uint32_t h, uint32_t ox, uint32_t oy, uint32_t oz)
{
    uint32_t m = (uint32_t)a->m, x = (h & 1023u) + ox, y = ((h >> 10) & 1023u) + oy, z = ((h >> 20) & 1023u) + oz;
    if (x >= m) x -= m;
    if (y >= m) y -= m;
    if (z >= m) z -= m;
    return (z * m + y) * m + x;
}

/* Find an offset sending bucket b (keys h[0..s)) to free slots and claim them. Candidates
 * are the offsets that put h[0] on a free slot, tried from a random place in the free list:
 * every one already satisfies the first key, and the list shrinks as H fills, so a search
 * never costs more than (free slots) x s. Returns 1 when placed, 0 when no offset works. */
static int place_bucket(attempt *a, uint32_t b, uint64_t *rng, size_t *work, uint32_t *offset_out)
{
    const uint32_t *h = a->bucket_h0 + a->bucket_start[b];
    size_t s = a->bucket_start[b + 1] - a->bucket_start[b], tries, t, start;
    uint32_t m = (uint32_t)a->m, h0x = h[0] & 1023u, h0y = (h[0] >> 10) & 1023u, h0z = (h[0] >> 20) & 1023u;
    if (a->nfree < s) return 0;
    start = (size_t)(rng_next(rng) % a->nfree);
    for (tries = 0; tries < a->nfree; tries++) {
        size_t idx = start + tries < a->nfree ? start + tries : start + tries - a->nfree;
        uint32_t slot = a->free_list[idx], sx = slot % m, sy = (slot / m) % m, sz = slot / (m * m);
        uint32_t ox = (sx + m - h0x) % m, oy = (sy + m - h0y) % m, oz = (sz + m - h0z) % m;
        int ok = 1;
        for (t = 1; t < s && ok; t++) ok = a->free_pos[shifted_slot(a, h[t], ox, oy, oz)] != NO_SLOT;
        *work += s;
        if (ok) {
            for (t = 0; t < s; t++) take_slot(a, shifted_slot(a, h[t], ox, oy, oz));
            *offset_out = pack3(ox, oy, oz);
            return 1;
        }
    }
    return 0;
}

/* Two keys of one bucket with the same h0 land on the same slot whatever the offset: only
 * other table sizes separate them. */
static int bucket_self_collides(attempt *a, uint32_t b)
{
    uint32_t t, m = (uint32_t)a->m;
    for (t = a->bucket_start[b]; t < a->bucket_start[b + 1]; t++) {
        uint32_t h = a->bucket_h0[t];
        uint32_t slot = (((h >> 20) & 1023u) * m + ((h >> 10) & 1023u)) * m + (h & 1023u);
        if (a->stamp[slot] == b + 1) return 1;
        a->stamp[slot] = b + 1;
    }
    return 0;
}

/* One greedy assignment at sizes (m, r). VSD_OK and offsets[r^3] filled, or
 * VSD_ERR_UNSUPPORTED with the reason in why, or VSD_ERR_NOMEM. */
static vsd_status try_assign(int m, int r, const uint32_t *keys, size_t K, int nx, int ny, uint64_t seed,
                             uint32_t *offsets, char *why, size_t whylen)
{
    attempt a;
    size_t o, work = 0, budget = (size_t)WORK_PER_KEY * K + ((size_t)1 << 20);
    uint64_t rng = seed ? seed : 1;
    vsd_status st;
    memset(&a, 0, sizeof a);
    a.m = m;
    a.r = r;
    a.K = K;
    a.m3 = (size_t)m * m * m;
    a.r3 = (size_t)r * r * r;
    st = attempt_buckets(&a, keys, nx, ny);
    a.free_list = malloc(a.m3 * sizeof *a.free_list);
    a.free_pos = malloc(a.m3 * sizeof *a.free_pos);
    a.stamp = calloc(a.m3, sizeof *a.stamp);
    if (st || !a.free_list || !a.free_pos || !a.stamp) {
        attempt_free(&a);
        return VSD_ERR_NOMEM;
    }
    for (o = 0; o < a.m3; o++) a.free_list[o] = a.free_pos[o] = (uint32_t)o;
    a.nfree = a.m3;
    memset(offsets, 0, a.r3 * sizeof *offsets);
    st = VSD_OK;
    for (o = 0; o < a.nonempty && st == VSD_OK; o++) {
        uint32_t b = a.order[o];
        size_t s = a.bucket_start[b + 1] - a.bucket_start[b];
        if (bucket_self_collides(&a, b)) {
            snprintf(why, whylen, "two of the %zu voxels of one offset slot share a hash slot", s);
            st = VSD_ERR_UNSUPPORTED;
        } else if (!place_bucket(&a, b, &rng, &work, &offsets[b])) {
            snprintf(why, whylen, "no offset puts a bucket of %zu voxels on free slots (%zu of %zu free)", s, a.nfree,
                     a.m3);
            st = VSD_ERR_UNSUPPORTED;
        } else if (work > budget) {
            snprintf(why, whylen, "offset search passed its budget of %zu steps", budget);
            st = VSD_ERR_UNSUPPORTED;
        }
    }
    attempt_free(&a);
    return st;
}

/* ---- the build ---- */

vsd_crm_hash_params vsd_crm_hash_default_params(void)
{
    vsd_crm_hash_params p;
    p.max_growths = VSD_CRM_HASH_MAX_GROWTHS;
    p.r_initial = 0;
    p.seed = 0x9E3779B97F4A7C15ull;
    return p;
}

/* Occupancy bits and the list of stored voxel indices (ascending). */
static vsd_status collect_keys(const int8_t *q, size_t n, size_t K, uint32_t *occupancy, uint32_t **keys_out)
{
    size_t v, t = 0;
    uint32_t *keys = malloc((K ? K : 1) * sizeof *keys);
    if (!keys) return VSD_ERR_NOMEM;
    for (v = 0; v < n; v++)
        if (q[v]) {
            occupancy[v >> 5] |= 1u << (v & 31);
            keys[t++] = (uint32_t)v;
        }
    *keys_out = keys;
    return VSD_OK;
}

/* Store each key's value at its slot. Every stored q is nonzero, so a slot already nonzero
 * means two keys share it: a bug in the assignment, caught here rather than in an image. */
static vsd_status fill_table(vsd_crm_hash *h, const int8_t *q, const uint32_t *keys, size_t K, char *err,
                             size_t errlen)
{
    size_t t;
    const vsd_crm_hash_view *v = &h->view;
    int m = v->m, r = v->r;
    for (t = 0; t < K; t++) {
        uint32_t n = keys[t];
        int i = (int)(n % (uint32_t)v->nx), j = (int)((n / (uint32_t)v->nx) % (uint32_t)v->ny),
            k = (int)(n / ((uint32_t)v->nx * (uint32_t)v->ny));
        uint32_t off = h->offsets[((size_t)(k % r) * r + (size_t)(j % r)) * r + (size_t)(i % r)];
        int x = (i % m + (int)(off & 1023u)) % m, y = (j % m + (int)((off >> 10) & 1023u)) % m,
            z = (k % m + (int)((off >> 20) & 1023u)) % m;
        size_t slot = ((size_t)z * m + (size_t)y) * m + (size_t)x;
        if (h->table[slot])
            return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "crm residual hash: voxel (%d, %d, %d) collides at slot %zu",
                            i, j, k, slot);
        h->table[slot] = q[n];
    }
    return VSD_OK;
}

/* Offset assignment, growing m and r alternately on failure (see below), bounded. */
static vsd_status hash_keys(vsd_crm_hash *h, const uint32_t *keys, size_t K, const vsd_crm_hash_params *p,
                            char *err, size_t errlen)
{
    char why[160] = "";
    int m = ceil_cbrt_ratio(K, 1), r, growths = 0;
    vsd_crm_hash_view *v = &h->view;
    if (m > VSD_CRM_HASH_MAX_M)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "crm residual hash: K = %zu stored voxels needs a hash table side %d > %d", K, m,
                        VSD_CRM_HASH_MAX_M);
    r = vsd_coprime_at_least(p->r_initial > 0 ? p->r_initial : ceil_cbrt_ratio(K, 3) + 9, m);
    h->stats.m_initial = m;
    h->stats.r_initial = r;
    for (;;) {
        vsd_status st;
        size_t r3 = (size_t)r * r * r;
        if (r > MAX_R) {
            snprintf(why, sizeof why, "r passed its limit %d", MAX_R);
            break;
        }
        free(h->offsets);
        h->offsets = malloc(r3 * sizeof *h->offsets);
        if (!h->offsets) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm residual hash: no memory for r = %d", r);
        h->stats.attempts++;
        st = try_assign(m, r, keys, K, v->nx, v->ny, p->seed, h->offsets, why, sizeof why);
        if (st == VSD_ERR_NOMEM)
            return vsd_fail(st, err, errlen, "crm residual hash: no memory for m = %d, r = %d (K = %zu)", m, r, K);
        if (st == VSD_OK) {
            v->m = m;
            v->r = r;
            v->n_offsets = r3;
            v->n_table = (size_t)m * m * m;
            return VSD_OK;
        }
        if (growths >= p->max_growths) break;
        growths++;
        /* Alternate: one more H side (free slots to spare, ~3/m more bytes of H at 1 byte a
         * slot) while m^3 stays within the load slack, then ~12% more r (smaller buckets, but
         * 4 bytes an offset slot). Measured on 128^3 residuals, structured ones (slabs, point
         * lattices) fail on the first sizes because earlier buckets leave the free slots in a
         * pattern no later bucket fits, not because H is full; either growth breaks it. */
        if (growths % 2 == 1 && (double)(m + 1) * (m + 1) * (m + 1) <= VSD_CRM_HASH_LOAD_SLACK * (double)K &&
            m < VSD_CRM_HASH_MAX_M)
            m++;
        else
            r += r / 8 > 1 ? r / 8 : 1;
        r = vsd_coprime_at_least(r, m);
    }
    return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                    "crm residual hash: gave up after %d growths: K = %zu stored voxels, offset table r = %d, hash "
                    "table m = %d (started at r = %d, m = %d); last attempt: %s",
                    growths, K, r, m, h->stats.r_initial, h->stats.m_initial, why);
}

vsd_status vsd_crm_hash_build(int nx, int ny, int nz, const float *residual, float quant_step, vsd_crm_hash **out,
                              char *err, size_t errlen)
{
    return vsd_crm_hash_build_ex(nx, ny, nz, residual, quant_step, NULL, out, err, errlen);
}

vsd_status vsd_crm_hash_build_ex(int nx, int ny, int nz, const float *residual, float quant_step,
                                 const vsd_crm_hash_params *params, vsd_crm_hash **out, char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds();
    vsd_crm_hash_params p = params ? *params : vsd_crm_hash_default_params();
    vsd_crm_hash *h = NULL;
    int8_t *q = NULL;
    uint32_t *keys = NULL;
    size_t n = 0, K = 0, words;
    vsd_status st;
    if (!out) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm residual hash: NULL output");
    *out = NULL;
    if (p.max_growths < 0)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm residual hash: max_growths %d < 0", p.max_growths);
    st = check_grid(nx, ny, nz, &n, err, errlen);
    if (st) return st;
    q = malloc(n);
    h = calloc(1, sizeof *h);
    words = (n + 31) / 32;
    if (h) h->occupancy = calloc(words, sizeof *h->occupancy);
    if (!q || !h || !h->occupancy) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm residual hash: no memory for %zu voxels", n);
        goto fail;
    }
    st = vsd_crm_quantise_residual(nx, ny, nz, residual, quant_step, q, &h->stats.quant_step, &K,
                                   &h->stats.clamped, err, errlen);
    if (st) goto fail;
    h->view.occupancy = h->occupancy;
    h->view.n_occupancy = words;
    h->view.nx = nx;
    h->view.ny = ny;
    h->view.nz = nz;
    h->view.step = h->stats.quant_step;
    if (collect_keys(q, n, K, h->occupancy, &keys)) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm residual hash: no memory for %zu keys", K);
        goto fail;
    }
    if (K > 0) {
        st = hash_keys(h, keys, K, &p, err, errlen);
        if (st) goto fail;
        h->table = calloc(h->view.n_table, 1);
        if (!h->table) {
            st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm residual hash: no memory for m = %d", h->view.m);
            goto fail;
        }
        st = fill_table(h, q, keys, K, err, errlen);
        if (st) goto fail;
        h->view.offsets = h->offsets;
        h->view.table = h->table;
    }
    h->stats.voxels = n;
    h->stats.stored = K;
    h->stats.m = h->view.m;
    h->stats.r = h->view.r;
    h->stats.bytes = words * sizeof(uint32_t) + h->view.n_offsets * sizeof(uint32_t) + h->view.n_table;
    free(q);
    free(keys);
    h->stats.build_seconds = vsd_clock_seconds() - t0;
    *out = h;
    return VSD_OK;
fail:
    free(q);
    free(keys);
    vsd_crm_hash_destroy(h);
    return st;
}

vsd_crm_hash_view vsd_crm_hash_get_view(const vsd_crm_hash *h) { return h->view; }
vsd_crm_hash_stats vsd_crm_hash_get_stats(const vsd_crm_hash *h) { return h->stats; }
size_t vsd_crm_hash_stored(const vsd_crm_hash *h) { return h->stats.stored; }
int vsd_crm_hash_table_side(const vsd_crm_hash *h) { return h->stats.m; }
int vsd_crm_hash_offset_side(const vsd_crm_hash *h) { return h->stats.r; }
size_t vsd_crm_hash_bytes(const vsd_crm_hash *h) { return h->stats.bytes; }
float vsd_crm_hash_quant_step(const vsd_crm_hash *h) { return h->stats.quant_step; }
double vsd_crm_hash_build_seconds(const vsd_crm_hash *h) { return h->stats.build_seconds; }

void vsd_crm_hash_destroy(vsd_crm_hash *h)
{
    if (!h) return;
    free(h->occupancy);
    free(h->offsets);
    free(h->table);
    free(h);
}
