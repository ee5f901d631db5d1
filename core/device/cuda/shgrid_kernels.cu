// CUDA entry points of method `shgrid` over the kernels it shares with the CPU backend
// (core/methods/shgrid/shgrid_kernel.h): the record pass (one thread per record) and the
// view pass (one thread per pixel sample). Host-side launching and device copies of the
// record grid arrive with the CUDA backend (issue 7); this file keeps the kernels
// CUDA-clean.
#include "methods/shgrid/shgrid_kernel.h"

// Reduced-intensity records [0, g->record_count): out[rec * g->stride ...].
__global__ void vsd_cuda_shgrid_records(const vsd_kshgrid *g, float *out)
{
    int rec = blockIdx.x * blockDim.x + threadIdx.x;
    if (rec >= g->record_count) return;
    vsd_shgrid_record(g, rec, out + (size_t)rec * g->stride);
}

// One sub-pixel sample (jx, jy) per pixel, added into out (the host divides by the count).
__global__ void vsd_cuda_shgrid_render(const vsd_kshgrid *g, float jx, float jy, vsd_sample_result *out)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= g->kd->camera.width || y >= g->kd->camera.height) return;
    vsd_sample_result r = vsd_shgrid_pixel(g, x, y, jx, jy);
    vsd_sample_result acc = out[y * g->kd->camera.width + x];
    acc.direct = f3_add(acc.direct, r.direct);
    acc.emit = f3_add(acc.emit, r.emit);
    acc.background = f3_add(acc.background, r.background);
    acc.transmittance += r.transmittance;
    out[y * g->kd->camera.width + x] = acc;
}
