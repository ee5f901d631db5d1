// CUDA entry points of the `constellation` method (Navarro et al. 2009): the validity-mask
// pass and the lighting pass, one thread per view ray, over the same kernel functions
// the CPU backend runs (methods/constellation/constellation_kernel.h). The host launcher
// arrives with the CUDA backend (issue 7); this file proves the kernels compile for the GPU.
#include "methods/constellation/constellation_kernel.h"

// Validity mask (§4.2): iFirst per view ray (pixel x sub-sample), -1 where empty.
__global__ void vsd_cuda_constellation_mask(const vsd_kconstellation *kc, int32_t *first)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = blockIdx.y * blockDim.y + threadIdx.y;
    int n2 = kc->pixel_samples * kc->pixel_samples;
    if (x >= kc->kd->camera.width || y >= kc->kd->camera.height) return;
    for (int s = 0; s < n2; s++)
        first[((size_t)y * kc->kd->camera.width + x) * n2 + s] = vsd_cst_first_shell(kc, x, y, s);
}

// Lighting pass: shells from iFirst with shadow rays to every light; the n x n sub-samples
// of a pixel are summed (the host divides by n^2, as vsd_accum_resolve does).
__global__ void vsd_cuda_constellation_light(const vsd_kconstellation *kc, vsd_sample_result *out)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = blockIdx.y * blockDim.y + threadIdx.y;
    int n2 = kc->pixel_samples * kc->pixel_samples;
    if (x >= kc->kd->camera.width || y >= kc->kd->camera.height) return;
    vsd_sample_result acc = vsd_cst_sample(kc, x, y, 0);
    for (int s = 1; s < n2; s++) {
        vsd_sample_result r = vsd_cst_sample(kc, x, y, s);
        acc.direct = f3_add(acc.direct, r.direct);
        acc.emit = f3_add(acc.emit, r.emit);
        acc.background = f3_add(acc.background, r.background);
        acc.transmittance += r.transmittance;
        acc.depth = fminf(acc.depth, r.depth);
    }
    out[y * kc->kd->camera.width + x] = acc;
}
