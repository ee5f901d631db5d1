// CUDA entry points over the shared kernels: one thread per pixel, the same per-pixel
// functions the CPU backend calls (core/methods/*/..._kernel.h). The host-side launcher
// and device memory management arrive with the CUDA backend (issue 7); this file proves
// the kernels compile for the GPU.
#include "methods/reference/reference_kernel.h"
#include "methods/raymarch/raymarch_kernel.h"

// One progressive round of path-tracing samples [s0, s1) per pixel, summed into out.
__global__ void vsd_cuda_reference_round(const vsd_kernel_data *kd, int s0, int s1, vsd_sample_result *out)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= kd->camera.width || y >= kd->camera.height) return;
    vsd_sample_result acc = out[y * kd->camera.width + x];
    for (int s = s0; s < s1; s++) {
        vsd_sample_result r = vsd_reference_sample(kd, x, y, (uint32_t)s);
        acc.direct = f3_add(acc.direct, r.direct);
        acc.indirect = f3_add(acc.indirect, r.indirect);
        acc.emit = f3_add(acc.emit, r.emit);
        acc.background = f3_add(acc.background, r.background);
        acc.transmittance += r.transmittance;
    }
    out[y * kd->camera.width + x] = acc;
}

__global__ void vsd_cuda_raymarch(const vsd_kernel_data *kd, vsd_sample_result *out)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= kd->camera.width || y >= kd->camera.height) return;
    out[y * kd->camera.width + x] = vsd_raymarch_pixel(kd, x, y, 0.5f, 0.5f);
}
