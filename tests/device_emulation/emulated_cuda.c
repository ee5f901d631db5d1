/* emulated_cuda.c — core/device/cuda/cuda_backend.h on the host, for tests on machines
 * without a GPU (tests/test_device_residency.c). It checks the library's side of the CUDA
 * backend, which the real backend cannot check without a device:
 *   - "device" buffers are separate allocations, poisoned when allocated, so a slot that
 *     is not re-copied when its contents changed keeps stale bytes (and an upload skipped
 *     while the host bytes differ is reported as stale);
 *   - every array pointer inside a kernel struct handed to a launcher must lie inside an
 *     emulated device allocation holding at least the bytes the kernels read (a host
 *     pointer or a short upload is reported);
 *   - the launchers run the shared kernel functions serially, in the CUDA entry files'
 *     per-pixel sample order;
 *   - slots are the backend's table by descriptor (core/device/cuda/cuda_slots.h): two
 *     descriptors of one name are reported (names tell slots apart in messages), and a
 *     change of method frees the method slots as the real backend does, so a buffer the
 *     new method reads without uploading it first is reported as not a device pointer.
 * emulated_cuda_errors counts what was reported. Linked before the vsd libraries, these
 * definitions take the place of the real backend (or of cuda_absent.c). */
#include "device/cuda/cuda_backend.h"
#include "device/cuda/cuda_slots.h"
#include "kernel/kernel_accum.h"
#include "device/device_pass.h"
#include "kernel/kernel_edt.h"
#include "src/grids/distance_map.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef vsd_cuda_resident buf;
struct vsd_cuda { vsd_cuda_slots slots; vsd_kernel_data *d_kd; void *d_method; size_t method_bytes; uint64_t uploaded; size_t budget; };

int emulated_cuda_errors = 0;
int vsd_cuda_built(void) { return 1; }
vsd_status vsd_cuda_open(vsd_cuda **out, char *err, size_t errlen)
{
    (void)err; (void)errlen;
    vsd_cuda *c = calloc(1, sizeof *c);
    const char *m = getenv("VSD_CUDA_MAX_MB");
    if (m && *m) c->budget = (size_t)strtoull(m, NULL, 10) << 20;
    c->d_kd = malloc(sizeof(vsd_kernel_data));
    c->d_method = malloc(4096); c->method_bytes = 4096;
    *out = c;
    return VSD_OK;
}
void vsd_cuda_close(vsd_cuda *c)
{
    if (!c) return;
    for (size_t i = 0; i < c->slots.n; i++) free(c->slots.v[i].ptr);
    free(c->slots.v);
    free(c->d_kd); free(c->d_method); free(c);
}
const char *vsd_cuda_device_name(const vsd_cuda *c) { (void)c; return "emulated CUDA (host)"; }
size_t vsd_cuda_resident_bytes(const vsd_cuda *c) { return vsd_cuda_slots_bytes(&c->slots); }
uint64_t vsd_cuda_uploaded_bytes(const vsd_cuda *c) { return c->uploaded; }
void vsd_cuda_seconds(const vsd_cuda *c, double *passes, double *downloads) { (void)c; *passes = *downloads = 0.0; }
void vsd_cuda_set_method(vsd_cuda *c, const char *method)
{
    if (!vsd_cuda_slots_method_changed(&c->slots, method)) return;
    for (size_t i = 0; i < c->slots.n; i++) {
        buf *b = &c->slots.v[i];
        if (b->slot->kind != VSD_CUDA_METHOD_SLOT) continue;
        free(b->ptr);
        b->ptr = NULL; b->bytes = b->used = 0; b->key = 0; b->valid = 0;
    }
}

/* s's entry (NULL after reporting when the host has no memory for it); a new descriptor
 * whose name another one has is reported. */
static buf *entry(vsd_cuda *c, vsd_cuda_slot s, char *err, size_t errlen)
{
    size_t n = c->slots.n, i;
    buf *b = vsd_cuda_slots_get(&c->slots, s);
    if (!b) { vsd_cuda_slots_no_entry(s, err, errlen); return NULL; }
    if (c->slots.n > n)
        for (i = 0; i < n; i++)
            if (strcmp(c->slots.v[i].slot->name, s->name) == 0) { fprintf(stderr, "emulated CUDA: two slots are named '%s'\n", s->name); emulated_cuda_errors++; }
    return b;
}

static vsd_status reserve(vsd_cuda *c, buf *b, size_t bytes, char *err, size_t errlen)
{
    if (b->bytes >= bytes) return VSD_OK;
    if (c->budget && vsd_cuda_resident_bytes(c) - b->bytes + bytes > c->budget)
        return vsd_cuda_slots_over_budget(&c->slots, b, bytes, c->budget, err, errlen);
    if (bytes > ((size_t)1 << 40)) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "CUDA: allocating %.1f MiB of device memory for %s: cudaErrorMemoryAllocation", (double)bytes/1048576.0, b->slot->name);
    free(b->ptr);
    b->ptr = malloc(bytes); memset(b->ptr, 0xA5, bytes);  /* poison */
    b->bytes = bytes; b->valid = 0;
    return VSD_OK;
}
vsd_status vsd_cuda_upload(vsd_cuda *c, vsd_cuda_slot s, uint64_t key, const void *host, size_t bytes, void **dev, char *err, size_t errlen)
{
    buf *b;
    *dev = NULL;
    if (!bytes) return VSD_OK;
    if (!(b = entry(c, s, err, errlen))) return VSD_ERR_NOMEM;
    if (key && b->valid && b->key == key && b->used == bytes) {
        if (memcmp(b->ptr, host, bytes)) { fprintf(stderr, "emulated CUDA: stale slot '%s' kept %zu bytes that differ from the host's\n", s->name, bytes); emulated_cuda_errors++; }
        *dev = b->ptr; return VSD_OK;
    }
    vsd_status st = reserve(c, b, bytes, err, errlen); if (st) return st;
    memcpy(b->ptr, host, bytes);
    c->uploaded += bytes; b->used = bytes; b->key = key; b->valid = 1; *dev = b->ptr;
    return VSD_OK;
}
vsd_status vsd_cuda_scratch(vsd_cuda *c, vsd_cuda_slot s, uint64_t key, size_t bytes, int zero, void **dev, char *err, size_t errlen)
{
    buf *b;
    *dev = NULL;
    if (!bytes) return VSD_OK;
    if (!(b = entry(c, s, err, errlen))) return VSD_ERR_NOMEM;
    vsd_status st = reserve(c, b, bytes, err, errlen); if (st) return st;
    if (zero) memset(b->ptr, 0, bytes); else memset(b->ptr, 0x5A, bytes);
    b->used = bytes; b->key = key; b->valid = 1; *dev = b->ptr;
    return VSD_OK;
}
vsd_status vsd_cuda_download(vsd_cuda *c, void *host, const void *dev, size_t bytes, char *err, size_t errlen)
{
    (void)c; (void)err; (void)errlen; if (bytes) memcpy(host, dev, bytes); return VSD_OK;
}

/* pointer checks */
static void chk(vsd_cuda *c, const void *p, size_t need, const char *what)
{
    if (!p) {
        if (need) {
            fprintf(stderr, "emulated CUDA: %s is NULL but %zu bytes may be read\n", what, need);
            emulated_cuda_errors++;
        }
        return;
    }
    if (p == (const void *)c->d_kd || p == c->d_method) return;
    for (size_t i = 0; i < c->slots.n; i++) {
        const buf *s = &c->slots.v[i];
        const char *b = s->ptr;
        if (b && (const char *)p >= b && (const char *)p < b + s->bytes) {
            if ((const char *)p + need > b + s->used) { fprintf(stderr, "emulated CUDA: %s needs %zu bytes, slot '%s' holds %zu\n", what, need, s->slot->name, s->used); emulated_cuda_errors++; }
            return;
        }
    }
    fprintf(stderr, "emulated CUDA: %s = %p is not a device pointer (host memory)\n", what, p); emulated_cuda_errors++;
}
static void chk_vol(vsd_cuda *c, const vsd_kvolume *v, const char *n)
{
    size_t cells = (size_t)v->dims[0] * v->dims[1] * v->dims[2];
    char w[64];
    snprintf(w, sizeof w, "%s.brick_slots", n); chk(c, v->brick_slots, cells * 4, w);
    snprintf(w, sizeof w, "%s.brick_max", n); chk(c, v->brick_max, cells * 4, w);
    if (v->brick_slots && cells) {
        int32_t mx = -1; size_t i;
        for (i = 0; i < cells; i++) if (v->brick_slots[i] > mx) mx = v->brick_slots[i];
        snprintf(w, sizeof w, "%s.voxels", n); chk(c, v->voxels, (size_t)(mx + 1) * 512 * 4, w);
    }
}
static void chk_kd(vsd_cuda *c, const vsd_kernel_data *kd)
{
    chk_vol(c, &kd->density, "density"); chk_vol(c, &kd->emission, "emission");
    chk(c, kd->env.rgb, (size_t)kd->env.width * kd->env.height * 12, "env.rgb");
    chk(c, kd->env.cdf_rows, (size_t)(kd->env.height + 1) * 4, "env.cdf_rows");
    chk(c, kd->env.cdf_cols, (size_t)kd->env.height * (kd->env.width + 1) * 4, "env.cdf_cols");
    chk(c, kd->lights, (size_t)kd->light_count * 32, "kd.lights");
    if (kd->volume_count > 1) {
        /* the volume table and each volume's bricks are device memory too */
        chk(c, kd->volumes, (size_t)kd->volume_count * sizeof *kd->volumes, "kd.volumes");
        for (int i = 0; kd->volumes && i < kd->volume_count; i++) {
            char n[64];
            snprintf(n, sizeof n, "volumes[%d].density", i); chk_vol(c, &kd->volumes[i].density, n);
            snprintf(n, sizeof n, "volumes[%d].emission", i); chk_vol(c, &kd->volumes[i].emission, n);
        }
    }
}
static const vsd_kernel_data *put_kd(vsd_cuda *c, const vsd_kernel_data *kd)
{
    chk_kd(c, kd);
    memcpy(c->d_kd, kd, sizeof *kd); c->uploaded += sizeof *kd;
    return c->d_kd;
}
static const void *put_method(vsd_cuda *c, const void *h, size_t n)
{
    memcpy(c->d_method, h, n); c->uploaded += n; return c->d_method;
}
static int cancelled(const vsd_cuda_progress *p) { return p && p->cancel && *p->cancel; }
static void prog(const vsd_cuda_progress *p, int y1, int h) { if (p && p->fn) p->fn(p->user, p->stage, p->base + p->span * (float)y1 / (float)h); }

/* The generic device pass (device/device_pass.h), run serially in the CUDA entries'
 * order: pixel passes add each pixel's samples in order, item passes write their items.
 * The struct's arrays (the pass's own list) and out must be emulated device memory. */
static void visit_array(void *user, const void *p, size_t bytes, const char *name)
{
    chk((vsd_cuda *)user, p, bytes, name);
}

vsd_status vsd_cuda_run_pass(vsd_cuda *c, const struct vsd_device_pass *pass, const void *m, const vsd_kernel_data *kd, vsd_pass_args a, int items, void *out, size_t out_bytes, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    unsigned char host[4096];
    const vsd_kernel_data *d = put_kd(c, kd);
    const void *dm = d;
    if (pass->struct_bytes) {
        if (pass->struct_bytes > sizeof host) { fprintf(stderr, "emulated CUDA: %s struct too large\n", pass->stage); emulated_cuda_errors++; return VSD_ERR_INTERNAL; }
        if (pass->arrays) pass->arrays(m, a, visit_array, c);
        memcpy(host, m, pass->struct_bytes);
        memcpy(host + pass->kd_offset, &d, sizeof d);
        dm = put_method(c, host, pass->struct_bytes);
    }
    chk(c, out, out_bytes, "out");
    if (pass->pixels) {
        int w = kd->camera.width, h = kd->camera.height;
        if ((size_t)w * h * VSD_ACC_N * sizeof(double) > out_bytes) { fprintf(stderr, "emulated CUDA: %s: sums of %zu bytes for %dx%d\n", pass->stage, out_bytes, w, h); emulated_cuda_errors++; }
        for (int y = 0; y < h; y++) {
            if (y % pass->band == 0 && cancelled(p)) return vsd_fail(VSD_ERR_CANCELLED, err, errlen, "render cancelled");
            for (int x = 0; x < w; x++)
                for (int s = a.first; s < a.first + a.count; s++) {
                    vsd_sample_result r = pass->sample(dm, x, y, s, a.n);
                    vsd_accum_sample((double *)out + ((size_t)y * w + x) * VSD_ACC_N, &r);
                }
        }
    } else {
        for (int i = 0; i < items; i++) {
            if (i % pass->band == 0 && cancelled(p)) return vsd_fail(VSD_ERR_CANCELLED, err, errlen, "render cancelled");
            pass->item(dm, i, a.n, out);
        }
    }
    prog(p, 1, 1);
    return VSD_OK;
}
vsd_status vsd_cuda_distance_map(vsd_cuda *c, const vsd_kvolume *kv, float threshold, uint8_t *skip_host, long long *occupied, char *err, size_t errlen)
{
    int32_t dims[3] = {8 * kv->dims[0], 8 * kv->dims[1], 8 * kv->dims[2]};
    size_t n = (size_t)dims[0] * dims[1] * dims[2], i;
    uint8_t *vocc = calloc(n, 1), *occ = calloc(n, 1); float *d2 = malloc(n * 4);
    long long cnt = 0;
    (void)err; (void)errlen;
    chk_vol(c, kv, "dm.volume");
    for (i = 0; i < n; i++) {
        int x = (int)(i % dims[0]), y = (int)((i / dims[0]) % dims[1]), z = (int)(i / ((size_t)dims[0] * dims[1]));
        int32_t s = kv->brick_slots[((size_t)(z >> 3) * kv->dims[1] + (y >> 3)) * kv->dims[0] + (x >> 3)];
        float v = s < 0 ? 0.0f : kv->voxels[(size_t)s * 512 + ((z & 7) * 8 + (y & 7)) * 8 + (x & 7)];
        vocc[i] = fabsf(v) > threshold;
    }
    for (i = 0; i < n; i++) {
        int x = (int)(i % dims[0]), y = (int)((i / dims[0]) % dims[1]), z = (int)(i / ((size_t)dims[0] * dims[1])), o = 0;
        for (int dz = 0; dz < 2 && z + dz < dims[2]; dz++) for (int dy = 0; dy < 2 && y + dy < dims[1]; dy++) for (int dx = 0; dx < 2 && x + dx < dims[0]; dx++)
            o |= vocc[((size_t)(z + dz) * dims[1] + (y + dy)) * dims[0] + (x + dx)];
        occ[i] = (uint8_t)o; cnt += o;
    }
    vsd_edt_squared(occ, dims, d2, 1);
    for (i = 0; i < n; i++) skip_host[i] = vsd_edt_skip(d2[i]);
    *occupied = cnt;
    free(vocc); free(occ); free(d2);
    return VSD_OK;
}
