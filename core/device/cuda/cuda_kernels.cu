// CUDA entry points of `reference` and `raymarch`: one thread per pixel over a band of
// rows, calling the per-sample functions the CPU tiles call (core/methods/*/..._kernel.h)
// and adding each result into the pixel's sums with the CPU's own accumulation, in the
// CPU's sample order.
#include "cuda_internal.cuh"
#include "methods/reference/reference_kernel.h"
#include "methods/raymarch/raymarch_kernel.h"

// One progressive round of path-tracing samples [s0, s1) per pixel.
__global__ void vsd_cuda_reference_kernel(const vsd_kernel_data *kd, int y0, int y1, int s0, int s1, double *accum)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = y0 + blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= kd->camera.width || y >= y1) return;
    double *px = accum + ((size_t)y * kd->camera.width + x) * VSD_ACC_N;
    for (int s = s0; s < s1; s++) {
        vsd_sample_result r = vsd_reference_sample(kd, x, y, (uint32_t)s);
        vsd_accum_sample(px, &r);
    }
}

// n x n stratified rays per pixel, in the order of src/render/stratified.c.
__global__ void vsd_cuda_raymarch_kernel(const vsd_kernel_data *kd, int y0, int y1, int n, double *accum)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = y0 + blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= kd->camera.width || y >= y1) return;
    double *px = accum + ((size_t)y * kd->camera.width + x) * VSD_ACC_N;
    float inv = 1.0f / (float)n;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            vsd_sample_result r = vsd_raymarch_pixel(kd, x, y, ((float)i + 0.5f) * inv, ((float)j + 0.5f) * inv);
            vsd_accum_sample(px, &r);
        }
}

extern "C" vsd_status vsd_cuda_reference_round(vsd_cuda *c, const vsd_kernel_data *kd, int s0, int s1,
                                               double *accum, const vsd_cuda_progress *p, char *err,
                                               size_t errlen)
{
    const vsd_kernel_data *dkd;
    vsd_status st = vsd_cuda_put_kd(c, kd, &dkd, err, errlen);
    if (st) return st;
    int w = kd->camera.width;
    return vsd_cuda_bands(c, kd->camera.height, 64, p, "path tracing", [&](int y0, int y1) {
        vsd_cuda_reference_kernel<<<vsd_cuda_grid(w, y1 - y0), vsd_cuda_block(), 0, c->stream>>>(dkd, y0, y1, s0, s1,
                                                                                               accum);
    }, err, errlen);
}

extern "C" vsd_status vsd_cuda_raymarch(vsd_cuda *c, const vsd_kernel_data *kd, int n, double *accum,
                                        const vsd_cuda_progress *p, char *err, size_t errlen)
{
    const vsd_kernel_data *dkd;
    vsd_status st = vsd_cuda_put_kd(c, kd, &dkd, err, errlen);
    if (st) return st;
    int w = kd->camera.width;
    return vsd_cuda_bands(c, kd->camera.height, 64, p, "ray marching", [&](int y0, int y1) {
        vsd_cuda_raymarch_kernel<<<vsd_cuda_grid(w, y1 - y0), vsd_cuda_block(), 0, c->stream>>>(dkd, y0, y1, n, accum);
    }, err, errlen);
}
