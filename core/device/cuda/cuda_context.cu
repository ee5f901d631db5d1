// The CUDA device layer: device discovery, the per-renderer stream, resident slots that
// upload only when their key changes (a table by slot descriptor, cuda_slots.h), and CUDA
// errors as vsd_status (cuda_backend.h).
#include "cuda_internal.cuh"
#include "vsd/clock.h"
#include <stdlib.h>
#include <string.h>

extern "C" int vsd_cuda_built(void) { return 1; }

vsd_status vsd_cuda_fail(cudaError_t e, const char *what, char *err, size_t errlen)
{
    vsd_status st = e == cudaErrorMemoryAllocation ? VSD_ERR_NOMEM
                  : (e == cudaErrorNoDevice || e == cudaErrorInsufficientDriver) ? VSD_ERR_UNSUPPORTED
                  : VSD_ERR_DEVICE;
    cudaGetLastError();   // clear a non-sticky error so the context stays usable
    return vsd_fail(st, err, errlen, "CUDA: %s: %s (%s)", what, cudaGetErrorString(e), cudaGetErrorName(e));
}

extern "C" vsd_status vsd_cuda_open(vsd_cuda **out, char *err, size_t errlen)
{
    int count = 0, dev = 0;
    const char *env = getenv("VSD_CUDA_DEVICE");
    cudaError_t e = cudaGetDeviceCount(&count);
    cudaDeviceProp prop;
    *out = NULL;
    if (e != cudaSuccess) return vsd_cuda_fail(e, "no usable CUDA device", err, errlen);
    if (count == 0) return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "CUDA: no CUDA device found");
    if (env && *env) dev = atoi(env);
    if (dev < 0 || dev >= count)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "VSD_CUDA_DEVICE=%s: only %d CUDA device(s)", env, count);
    if ((e = cudaSetDevice(dev)) != cudaSuccess) return vsd_cuda_fail(e, "selecting the device", err, errlen);
    if ((e = cudaGetDeviceProperties(&prop, dev)) != cudaSuccess)
        return vsd_cuda_fail(e, "reading the device properties", err, errlen);
    vsd_cuda *c = (vsd_cuda *)calloc(1, sizeof *c);
    if (!c) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    c->device = dev;
    const char *max_mb = getenv("VSD_CUDA_MAX_MB");
    if (max_mb && *max_mb) c->budget = (size_t)strtoull(max_mb, NULL, 10) << 20;
    snprintf(c->name, sizeof c->name, "%.200s (sm_%d%d, %.0f GiB)", prop.name, prop.major, prop.minor,
             (double)prop.totalGlobalMem / (1024.0 * 1024.0 * 1024.0));
    if ((e = cudaStreamCreateWithFlags(&c->stream, cudaStreamNonBlocking)) != cudaSuccess) {
        free(c);
        return vsd_cuda_fail(e, "creating a stream", err, errlen);
    }
    if ((e = cudaMalloc((void **)&c->d_kd, sizeof(vsd_kernel_data))) != cudaSuccess) {
        vsd_cuda_close(c);
        return vsd_cuda_fail(e, "allocating the kernel data", err, errlen);
    }
    *out = c;
    return VSD_OK;
}

extern "C" void vsd_cuda_close(vsd_cuda *c)
{
    if (!c) return;
    cudaSetDevice(c->device);
    if (c->stream) cudaStreamSynchronize(c->stream);
    for (size_t i = 0; i < c->slots.n; i++) cudaFree(c->slots.v[i].ptr);
    free(c->slots.v);
    cudaFree(c->d_kd);
    cudaFree(c->d_method);
    if (c->stream) cudaStreamDestroy(c->stream);
    cudaGetLastError();   // leave no error behind for the next context on this thread
    free(c);
}

extern "C" const char *vsd_cuda_device_name(const vsd_cuda *c) { return c->name; }

extern "C" size_t vsd_cuda_resident_bytes(const vsd_cuda *c) { return vsd_cuda_slots_bytes(&c->slots); }

extern "C" uint64_t vsd_cuda_uploaded_bytes(const vsd_cuda *c) { return c->uploaded; }

extern "C" void vsd_cuda_set_method(vsd_cuda *c, const char *method)
{
    if (!vsd_cuda_slots_method_changed(&c->slots, method)) return;
    vsd_cuda_use(c);
    cudaStreamSynchronize(c->stream);   // a launch may still read them (none does: passes end synchronised)
    cudaGetLastError();
    for (size_t i = 0; i < c->slots.n; i++) {
        vsd_cuda_resident *b = &c->slots.v[i];
        if (b->slot->kind != VSD_CUDA_METHOD_SLOT || !b->ptr) continue;
        cudaFree(b->ptr);
        b->ptr = NULL;
        b->bytes = b->used = 0;
        b->key = 0;
        b->valid = 0;
    }
}

// Grows b, the entry of its slot, to hold `bytes` (allocations only grow, so a view of a
// new size or the next frame's bricks reuse the buffer when they fit).
static vsd_status slot_reserve(vsd_cuda *c, vsd_cuda_resident *b, size_t bytes, char *err, size_t errlen)
{
    if (b->bytes >= bytes) return VSD_OK;
    if (c->budget && vsd_cuda_resident_bytes(c) - b->bytes + bytes > c->budget)
        return vsd_cuda_slots_over_budget(&c->slots, b, bytes, c->budget, err, errlen);
    cudaError_t e = cudaStreamSynchronize(c->stream);   // the old buffer may still be read
    if (e != cudaSuccess) return vsd_cuda_fail(e, "waiting for the stream", err, errlen);
    cudaFree(b->ptr);
    b->ptr = NULL;
    b->bytes = 0;
    b->valid = 0;
    if ((e = cudaMalloc(&b->ptr, bytes)) != cudaSuccess) {
        char what[256];
        snprintf(what, sizeof what, "allocating %.1f MiB of device memory for %.160s", (double)bytes / (1024.0 * 1024.0),
                 b->slot->name);
        b->ptr = NULL;
        return vsd_cuda_fail(e, what, err, errlen);
    }
    b->bytes = bytes;
    return VSD_OK;
}

extern "C" vsd_status vsd_cuda_upload(vsd_cuda *c, vsd_cuda_slot slot, uint64_t key, const void *host, size_t bytes,
                                      void **dev, char *err, size_t errlen)
{
    vsd_cuda_use(c);
    *dev = NULL;
    if (bytes == 0) return VSD_OK;
    vsd_cuda_resident *b = vsd_cuda_slots_get(&c->slots, slot);
    if (!b) return vsd_cuda_slots_no_entry(slot, err, errlen);
    if (key != 0 && b->valid && b->key == key && b->used == bytes) {
        *dev = b->ptr;
        return VSD_OK;
    }
    vsd_status st = slot_reserve(c, b, bytes, err, errlen);
    if (st) return st;
    b->valid = 0;
    cudaError_t e = cudaMemcpyAsync(b->ptr, host, bytes, cudaMemcpyHostToDevice, c->stream);
    if (e != cudaSuccess) return vsd_cuda_fail(e, "copying to the device", err, errlen);
    c->uploaded += bytes;
    b->used = bytes;
    b->key = key;
    b->valid = 1;
    *dev = b->ptr;
    return VSD_OK;
}

extern "C" vsd_status vsd_cuda_scratch(vsd_cuda *c, vsd_cuda_slot slot, uint64_t key, size_t bytes, int zero,
                                       void **dev, char *err, size_t errlen)
{
    vsd_cuda_use(c);
    *dev = NULL;
    if (bytes == 0) return VSD_OK;
    vsd_cuda_resident *b = vsd_cuda_slots_get(&c->slots, slot);
    if (!b) return vsd_cuda_slots_no_entry(slot, err, errlen);
    vsd_status st = slot_reserve(c, b, bytes, err, errlen);
    if (st) return st;
    if (zero) {
        cudaError_t e = cudaMemsetAsync(b->ptr, 0, bytes, c->stream);
        if (e != cudaSuccess) return vsd_cuda_fail(e, "clearing device memory", err, errlen);
    }
    b->used = bytes;
    b->key = key;
    b->valid = 1;
    *dev = b->ptr;
    return VSD_OK;
}

extern "C" vsd_status vsd_cuda_download(vsd_cuda *c, void *host, const void *dev, size_t bytes, char *err,
                                        size_t errlen)
{
    vsd_cuda_use(c);
    if (bytes == 0) return VSD_OK;
    double t0 = vsd_clock_seconds();
    cudaError_t e = cudaMemcpyAsync(host, dev, bytes, cudaMemcpyDeviceToHost, c->stream);
    if (e != cudaSuccess) return vsd_cuda_fail(e, "copying from the device", err, errlen);
    vsd_status st = vsd_cuda_finish(c, "copying from the device", err, errlen);
    c->download_seconds += vsd_clock_seconds() - t0;
    return st;
}

extern "C" void vsd_cuda_seconds(const vsd_cuda *c, double *passes, double *downloads)
{
    *passes = c->pass_seconds;
    *downloads = c->download_seconds;
}

vsd_status vsd_cuda_put_kd(vsd_cuda *c, const vsd_kernel_data *kd, const vsd_kernel_data **dkd, char *err,
                           size_t errlen)
{
    vsd_cuda_use(c);
    cudaError_t e = cudaMemcpyAsync(c->d_kd, kd, sizeof *kd, cudaMemcpyHostToDevice, c->stream);
    if (e != cudaSuccess) return vsd_cuda_fail(e, "copying the kernel data", err, errlen);
    c->uploaded += sizeof *kd;
    *dkd = c->d_kd;
    return VSD_OK;
}

vsd_status vsd_cuda_put_method(vsd_cuda *c, const void *host, size_t bytes, const void **dev, char *err,
                               size_t errlen)
{
    cudaError_t e;
    if (c->method_bytes < bytes) {
        if ((e = cudaStreamSynchronize(c->stream)) != cudaSuccess)
            return vsd_cuda_fail(e, "waiting for the stream", err, errlen);
        cudaFree(c->d_method);
        c->d_method = NULL;
        c->method_bytes = 0;
        if ((e = cudaMalloc(&c->d_method, bytes)) != cudaSuccess)
            return vsd_cuda_fail(e, "allocating the method data", err, errlen);
        c->method_bytes = bytes;
    }
    e = cudaMemcpyAsync(c->d_method, host, bytes, cudaMemcpyHostToDevice, c->stream);
    if (e != cudaSuccess) return vsd_cuda_fail(e, "copying the method data", err, errlen);
    c->uploaded += bytes;
    *dev = c->d_method;
    return VSD_OK;
}

vsd_status vsd_cuda_finish(vsd_cuda *c, const char *what, char *err, size_t errlen)
{
    cudaError_t e = cudaGetLastError();
    if (e == cudaSuccess) e = cudaStreamSynchronize(c->stream);
    return e == cudaSuccess ? VSD_OK : vsd_cuda_fail(e, what, err, errlen);
}

extern "C" vsd_status vsd_cuda_run_pass(vsd_cuda *c, const vsd_device_pass *pass, const void *m,
                                        const vsd_kernel_data *kd, vsd_pass_args a, int items, void *out,
                                        size_t out_bytes, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    // the method's struct with its kd member pointing at the device kd; kernel structs are
    // at most a few KiB (vsd_kconstellation is the largest at 1.2 KiB)
    unsigned char host[4096];
    const vsd_kernel_data *dkd;
    const void *dm;
    (void)out_bytes;
    if (!pass->cuda)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "%s: this build has no CUDA entry for the pass", pass->stage);
    if (pass->struct_bytes > sizeof host || (pass->struct_bytes && pass->kd_offset + sizeof dkd > pass->struct_bytes))
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "%s: kernel struct of %zu bytes (kd at %zu) does not fit",
                        pass->stage, pass->struct_bytes, pass->kd_offset);
    vsd_status st = vsd_cuda_put_kd(c, kd, &dkd, err, errlen);
    if (st) return st;
    dm = dkd;
    if (pass->struct_bytes) {
        memcpy(host, m, pass->struct_bytes);
        memcpy(host + pass->kd_offset, &dkd, sizeof dkd);
        if ((st = vsd_cuda_put_method(c, host, pass->struct_bytes, &dm, err, errlen))) return st;
    }
    int width = kd->camera.width;
    double t0 = vsd_clock_seconds();
    st = vsd_cuda_bands(c, pass->pixels ? kd->camera.height : items, pass->band, p, pass->stage, [&](int b0, int b1) {
        pass->cuda((void *)c->stream, dm, dkd, width, b0, b1, a, out);
    }, err, errlen);
    c->pass_seconds += vsd_clock_seconds() - t0;
    return st;
}
