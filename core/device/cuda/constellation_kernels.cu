// CUDA entry points of the `constellation` method (Navarro et al. 2009): the validity-mask
// pass and the lighting pass, one thread per pixel, over the same kernel functions the
// CPU backend runs (methods/constellation/constellation_kernel.h).
#include "cuda_internal.cuh"
#include "methods/constellation/constellation_kernel.h"

// Validity mask (§4.2): iFirst per view ray (pixel x sub-sample), -1 where empty.
__global__ void vsd_cuda_constellation_mask_kernel(const vsd_kconstellation *kc, int y0, int y1, int32_t *first)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = y0 + blockIdx.y * blockDim.y + threadIdx.y;
    int n2 = kc->pixel_samples * kc->pixel_samples;
    if (x >= kc->kd->camera.width || y >= y1) return;
    for (int s = 0; s < n2; s++)
        first[((size_t)y * kc->kd->camera.width + x) * n2 + s] = vsd_cst_first_shell(kc, x, y, s);
}

// Lighting pass: shells from iFirst with shadow rays to every light, each sub-sample added
// into the pixel's sums as the CPU's light_tile does.
__global__ void vsd_cuda_constellation_light_kernel(const vsd_kconstellation *kc, int y0, int y1, double *accum)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = y0 + blockIdx.y * blockDim.y + threadIdx.y;
    int n2 = kc->pixel_samples * kc->pixel_samples;
    if (x >= kc->kd->camera.width || y >= y1) return;
    double *px = accum + ((size_t)y * kc->kd->camera.width + x) * VSD_ACC_N;
    for (int s = 0; s < n2; s++) {
        vsd_sample_result r = vsd_cst_sample(kc, x, y, s);
        vsd_accum_sample(px, &r);
    }
}

extern "C" vsd_status vsd_cuda_constellation_mask(vsd_cuda *c, const vsd_kconstellation *kc,
                                                  const vsd_kernel_data *kd, int32_t *first,
                                                  const vsd_cuda_progress *p, char *err, size_t errlen)
{
    const vsd_kconstellation *dkc;
    vsd_status st = vsd_cuda_put_with_kd(c, kc, kd, &dkc, err, errlen);
    if (st) return st;
    int w = kd->camera.width;
    return vsd_cuda_bands(c, kd->camera.height, 256, p, "validity mask", [&](int y0, int y1) {
        vsd_cuda_constellation_mask_kernel<<<vsd_cuda_grid(w, y1 - y0), vsd_cuda_block(), 0, c->stream>>>(dkc, y0, y1,
                                                                                                        first);
    }, err, errlen);
}

extern "C" vsd_status vsd_cuda_constellation_light(vsd_cuda *c, const vsd_kconstellation *kc,
                                                   const vsd_kernel_data *kd, double *accum,
                                                   const vsd_cuda_progress *p, char *err, size_t errlen)
{
    const vsd_kconstellation *dkc;
    vsd_status st = vsd_cuda_put_with_kd(c, kc, kd, &dkc, err, errlen);
    if (st) return st;
    int w = kd->camera.width;
    return vsd_cuda_bands(c, kd->camera.height, 128, p, "lighting", [&](int y0, int y1) {
        vsd_cuda_constellation_light_kernel<<<vsd_cuda_grid(w, y1 - y0), vsd_cuda_block(), 0, c->stream>>>(dkc, y0, y1,
                                                                                                         accum);
    }, err, errlen);
}
