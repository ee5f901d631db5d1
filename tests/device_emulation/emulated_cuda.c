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
 *     per-pixel sample order.
 * emulated_cuda_errors counts what was reported. Linked before the vsd libraries, these
 * definitions take the place of the real backend (or of cuda_absent.c). */
#include "device/cuda/cuda_backend.h"
#include "kernel/kernel_accum.h"
#include "kernel/kernel_edt.h"
#include "methods/constellation/constellation_kernel.h"
#include "methods/shgrid/shgrid_kernel.h"
#include "methods/reference/reference_kernel.h"
#include "methods/raymarch/raymarch_kernel.h"
#include "src/render/distance_map.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct { void *ptr; size_t bytes, used; uint64_t key; int valid; } buf;
struct vsd_cuda { buf slot[VSD_SLOT_COUNT]; vsd_kernel_data *d_kd; void *d_method; size_t method_bytes; uint64_t uploaded; size_t budget; };

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
    for (int i = 0; i < VSD_SLOT_COUNT; i++) free(c->slot[i].ptr);
    free(c->d_kd); free(c->d_method); free(c);
}
const char *vsd_cuda_device_name(const vsd_cuda *c) { (void)c; return "emulated CUDA (host)"; }
size_t vsd_cuda_resident_bytes(const vsd_cuda *c) { size_t n = 0; for (int i = 0; i < VSD_SLOT_COUNT; i++) n += c->slot[i].bytes; return n; }
uint64_t vsd_cuda_uploaded_bytes(const vsd_cuda *c) { return c->uploaded; }

static vsd_status reserve(vsd_cuda *c, vsd_cuda_slot s, size_t bytes, char *err, size_t errlen)
{
    buf *b = &c->slot[s];
    if (b->bytes >= bytes) return VSD_OK;
    if (c->budget && vsd_cuda_resident_bytes(c) - b->bytes + bytes > c->budget)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "CUDA: would exceed VSD_CUDA_MAX_MB=%zu", c->budget >> 20);
    if (bytes > ((size_t)1 << 40)) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "CUDA: allocating %.1f MiB of device memory: cudaErrorMemoryAllocation", (double)bytes/1048576.0);
    free(b->ptr);
    b->ptr = malloc(bytes); memset(b->ptr, 0xA5, bytes);  /* poison */
    b->bytes = bytes; b->valid = 0;
    return VSD_OK;
}
vsd_status vsd_cuda_upload(vsd_cuda *c, vsd_cuda_slot s, uint64_t key, const void *host, size_t bytes, void **dev, char *err, size_t errlen)
{
    buf *b = &c->slot[s];
    *dev = NULL;
    if (!bytes) return VSD_OK;
    if (key && b->valid && b->key == key && b->used == bytes) {
        if (memcmp(b->ptr, host, bytes)) { fprintf(stderr, "emulated CUDA: stale slot %d kept %zu bytes that differ from the host's\n", s, bytes); emulated_cuda_errors++; }
        *dev = b->ptr; return VSD_OK;
    }
    vsd_status st = reserve(c, s, bytes, err, errlen); if (st) return st;
    memcpy(b->ptr, host, bytes);
    c->uploaded += bytes; b->used = bytes; b->key = key; b->valid = 1; *dev = b->ptr;
    return VSD_OK;
}
vsd_status vsd_cuda_scratch(vsd_cuda *c, vsd_cuda_slot s, uint64_t key, size_t bytes, int zero, void **dev, char *err, size_t errlen)
{
    buf *b = &c->slot[s];
    *dev = NULL;
    if (!bytes) return VSD_OK;
    vsd_status st = reserve(c, s, bytes, err, errlen); if (st) return st;
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
    for (int i = 0; i < VSD_SLOT_COUNT; i++) {
        const char *b = c->slot[i].ptr;
        if (b && (const char *)p >= b && (const char *)p < b + c->slot[i].bytes) {
            if ((const char *)p + need > b + c->slot[i].used) { fprintf(stderr, "emulated CUDA: %s needs %zu bytes, slot %d holds %zu\n", what, need, i, c->slot[i].used); emulated_cuda_errors++; }
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

vsd_status vsd_cuda_reference_round(vsd_cuda *c, const vsd_kernel_data *kd, int s0, int s1, double *accum, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    const vsd_kernel_data *d = put_kd(c, kd);
    chk(c, accum, (size_t)kd->camera.width * kd->camera.height * VSD_ACC_N * 8, "accum");
    for (int y = 0; y < kd->camera.height; y++) {
        if (y % 64 == 0 && cancelled(p)) return vsd_fail(VSD_ERR_CANCELLED, err, errlen, "render cancelled");
        for (int x = 0; x < kd->camera.width; x++)
            for (int s = s0; s < s1; s++) { vsd_sample_result r = vsd_reference_sample(d, x, y, (uint32_t)s); vsd_accum_sample(accum + ((size_t)y * kd->camera.width + x) * VSD_ACC_N, &r); }
    }
    prog(p, kd->camera.height, kd->camera.height);
    return VSD_OK;
}
vsd_status vsd_cuda_raymarch(vsd_cuda *c, const vsd_kernel_data *kd, int n, double *accum, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    const vsd_kernel_data *d = put_kd(c, kd);
    float inv = 1.0f / (float)n;
    (void)err; (void)errlen;
    for (int y = 0; y < kd->camera.height; y++)
        for (int x = 0; x < kd->camera.width; x++)
            for (int j = 0; j < n; j++) for (int i = 0; i < n; i++) {
                vsd_sample_result r = vsd_raymarch_pixel(d, x, y, ((float)i + 0.5f) * inv, ((float)j + 0.5f) * inv);
                vsd_accum_sample(accum + ((size_t)y * kd->camera.width + x) * VSD_ACC_N, &r);
            }
    prog(p, 1, 1);
    return VSD_OK;
}
static void chk_grid(vsd_cuda *c, const vsd_krecord_grid *g, int view, int lights)
{
    size_t rc = (size_t)g->record_count, dc = (size_t)g->dir_count, n2 = (size_t)g->n2, lc = (size_t)g->light_count;
    if (view) chk(c, g->cell_record, (size_t)g->res[0] * g->res[1] * g->res[2] * 4, "sh.cell_record");
    if (view) chk(c, g->records, rc * g->stride * 4, "sh.records");
    chk(c, g->record_pos, view ? 0 : rc * 16, "sh.record_pos");
    if (!view && !lights) { chk(c, g->dirs, dc * 16, "sh.dirs"); chk(c, g->basis, dc * n2 * 4, "sh.basis"); }
    if (!view && !lights && g->kind == VSD_RECORDS_SH_RGB) chk(c, g->dir_radiance, dc * 16, "sh.dir_radiance");
    if (view && g->kind == VSD_RECORDS_SH_SCALAR) chk(c, g->light, 3 * n2 * 4, "sh.light");
    if (view || lights) chk(c, g->lights, lc * 32, "sh.lights");
    if (view) chk(c, g->light_trans, rc * lc * 4, "sh.light_trans");
}
vsd_status vsd_cuda_shgrid_records(vsd_cuda *c, const struct vsd_krecord_grid *g, const vsd_kernel_data *kd, int lights, float *out, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    vsd_krecord_grid h = *g; const vsd_krecord_grid *dg;
    (void)err; (void)errlen;
    h.kd = put_kd(c, kd); dg = put_method(c, &h, sizeof h);
    chk_grid(c, g, 0, lights);
    chk(c, out, (size_t)g->record_count * (lights ? g->light_count : g->stride) * 4, "sh.out");
    for (int r = 0; r < g->record_count; r++) {
        if (lights) vsd_shgrid_light_record(dg, r, out + (size_t)r * g->light_count);
        else vsd_shgrid_record(dg, r, out + (size_t)r * g->stride);
    }
    prog(p, 1, 1);
    return VSD_OK;
}
vsd_status vsd_cuda_shgrid_view(vsd_cuda *c, const struct vsd_krecord_grid *g, const vsd_kernel_data *kd, int n, double *accum, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    vsd_krecord_grid h = *g; const vsd_krecord_grid *dg;
    float inv = 1.0f / (float)n;
    (void)err; (void)errlen;
    h.kd = put_kd(c, kd); dg = put_method(c, &h, sizeof h);
    chk_grid(c, g, 1, 0);
    for (int y = 0; y < kd->camera.height; y++)
        for (int x = 0; x < kd->camera.width; x++)
            for (int j = 0; j < n; j++) for (int i = 0; i < n; i++) {
                vsd_sample_result r = vsd_records_pixel(dg, x, y, ((float)i + 0.5f) * inv, ((float)j + 0.5f) * inv);
                vsd_accum_sample(accum + ((size_t)y * kd->camera.width + x) * VSD_ACC_N, &r);
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
static void chk_dm(vsd_cuda *c, const vsd_kdistmap *m, int skip_read, const char *n)
{
    size_t cells = (size_t)m->dims[0] * m->dims[1] * m->dims[2], vox = (size_t)(m->dims[0] + 1) * (m->dims[1] + 1) * (m->dims[2] + 1);
    char w[64];
    snprintf(w, sizeof w, "%s.skip", n); chk(c, m->skip, 0, w); if (m->skip) chk(c, m->skip, cells, w);
    snprintf(w, sizeof w, "%s.field", n); if (m->field) chk(c, m->field, vox * 4, w);
    snprintf(w, sizeof w, "%s.shadow_code", n); if (m->field) chk(c, m->shadow_code, cells, w);
    (void)skip_read;
}
vsd_status vsd_cuda_constellation_mask(vsd_cuda *c, const struct vsd_kconstellation *kc, const vsd_kernel_data *kd, int32_t *first, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    vsd_kconstellation h = *kc; const vsd_kconstellation *d; int n2 = kc->pixel_samples * kc->pixel_samples;
    (void)err; (void)errlen;
    h.kd = put_kd(c, kd); d = put_method(c, &h, sizeof h);
    chk_dm(c, &kc->dm_density, 1, "dm_density"); chk_dm(c, &kc->dm_emission, 1, "dm_emission");
    chk(c, first, (size_t)kd->camera.width * kd->camera.height * n2 * 4, "first(out)");
    for (int y = 0; y < kd->camera.height; y++) for (int x = 0; x < kd->camera.width; x++) for (int s = 0; s < n2; s++)
        first[((size_t)y * kd->camera.width + x) * n2 + s] = vsd_cst_first_shell(d, x, y, s);
    prog(p, 1, 1);
    return VSD_OK;
}
vsd_status vsd_cuda_constellation_light(vsd_cuda *c, const struct vsd_kconstellation *kc, const vsd_kernel_data *kd, double *accum, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    vsd_kconstellation h = *kc; const vsd_kconstellation *d; int n2 = kc->pixel_samples * kc->pixel_samples;
    (void)err; (void)errlen;
    h.kd = put_kd(c, kd); d = put_method(c, &h, sizeof h);
    chk_dm(c, &kc->dm_density, 1, "dm_density"); chk_dm(c, &kc->dm_emission, 1, "dm_emission");
    if (kc->first) chk(c, kc->first, (size_t)kd->camera.width * kd->camera.height * n2 * 4, "first");
    for (int y = 0; y < kd->camera.height; y++) for (int x = 0; x < kd->camera.width; x++) for (int s = 0; s < n2; s++) {
        vsd_sample_result r = vsd_cst_sample(d, x, y, s);
        vsd_accum_sample(accum + ((size_t)y * kd->camera.width + x) * VSD_ACC_N, &r);
    }
    prog(p, 1, 1);
    return VSD_OK;
}
