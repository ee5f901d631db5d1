// cuda_internal.cuh — what the CUDA entry files share: the context struct, CUDA error to
// vsd_status conversion, the per-launch parameter copies and the band loop that launches a
// kernel over rows of the image with progress and cancel between launches.
#ifndef VSD_CUDA_INTERNAL_CUH
#define VSD_CUDA_INTERNAL_CUH
#include "cuda_backend.h"
#include "cuda_slots.h"
#include "kernel/kernel_accum.h"
#include <cuda_runtime.h>
#include <stdio.h>

struct vsd_cuda {
    int device;
    cudaStream_t stream;
    char name[300];
    vsd_cuda_slots slots;   // the resident slots, by descriptor (cuda_slots.h)
    // per-launch copies of the kernel structs (the scene's and the method's)
    vsd_kernel_data *d_kd;
    void *d_method;
    size_t method_bytes;
    uint64_t uploaded;
    double pass_seconds, download_seconds;   // host wall time in passes and downloads (vsd_cuda_seconds)
    size_t budget;     // most bytes the slots may hold ($VSD_CUDA_MAX_MB), 0 = the device's memory
};

// Makes c's device current on the calling thread (CUDA's current device is per thread, and
// a daemon worker may render with a renderer another thread opened).
inline void vsd_cuda_use(const vsd_cuda *c) { cudaSetDevice(c->device); }

// The vsd_status for a CUDA error, with CUDA's name and message and what was being done.
vsd_status vsd_cuda_fail(cudaError_t e, const char *what, char *err, size_t errlen);

// Copies kd (device pointers inside) to the device; returns its device address.
vsd_status vsd_cuda_put_kd(vsd_cuda *c, const vsd_kernel_data *kd, const vsd_kernel_data **dkd, char *err,
                           size_t errlen);
// Copies a method struct of `bytes` to the device; returns its device address.
vsd_status vsd_cuda_put_method(vsd_cuda *c, const void *host, size_t bytes, const void **dev, char *err,
                               size_t errlen);

// Waits for the stream and turns a launch or execution error into a status.
vsd_status vsd_cuda_finish(vsd_cuda *c, const char *what, char *err, size_t errlen);

// Launches `launch(y0, y1)` over bands of image rows [0, height), synchronising after each
// band to report progress and honour cancel; the image in accum stays valid for the rows done.
template <typename Launch>
vsd_status vsd_cuda_bands(vsd_cuda *c, int height, int band, const vsd_cuda_progress *p, const char *what,
                          Launch launch, char *err, size_t errlen)
{
    for (int y0 = 0; y0 < height; y0 += band) {
        int y1 = y0 + band < height ? y0 + band : height;
        if (p && p->cancel && *p->cancel) return vsd_fail(VSD_ERR_CANCELLED, err, errlen, "render cancelled");
        launch(y0, y1);
        vsd_status st = vsd_cuda_finish(c, what, err, errlen);
        if (st) return st;
        if (p && p->fn) p->fn(p->user, p->stage, p->base + p->span * (float)y1 / (float)height);
    }
    return VSD_OK;
}

// A 16x8 block over a band of rows of a width-wide image.
inline dim3 vsd_cuda_block() { return dim3(16, 8); }
inline dim3 vsd_cuda_grid(int width, int rows)
{
    return dim3((unsigned)((width + 15) / 16), (unsigned)((rows + 7) / 8));
}

#endif
