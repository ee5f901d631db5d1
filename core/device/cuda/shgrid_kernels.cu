// CUDA entry points of method `shgrid` over the kernels it shares with the CPU backend
// (core/methods/shgrid/shgrid_kernel.h): the record pass, one thread per record (the
// paper's per-frame GPU pass), and the view pass, one thread per pixel.
#include "cuda_internal.cuh"
#include "methods/shgrid/shgrid_kernel.h"

// lights == 0: the SH records (stride floats each); else the transmittance toward each
// extracted light (light_count floats each).
__global__ void vsd_cuda_shgrid_records_kernel(const vsd_krecord_grid *g, int r0, int r1, int lights, float *out)
{
    int rec = r0 + blockIdx.x * blockDim.x + threadIdx.x;
    if (rec >= r1) return;
    if (lights) vsd_shgrid_light_record(g, rec, out + (size_t)rec * g->light_count);
    else vsd_shgrid_record(g, rec, out + (size_t)rec * g->stride);
}

// n x n stratified rays per pixel, in the order of src/render/stratified.c.
__global__ void vsd_cuda_shgrid_view_kernel(const vsd_krecord_grid *g, int y0, int y1, int n, double *accum)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = y0 + blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= g->kd->camera.width || y >= y1) return;
    double *px = accum + ((size_t)y * g->kd->camera.width + x) * VSD_ACC_N;
    float inv = 1.0f / (float)n;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            vsd_sample_result r = vsd_records_pixel(g, x, y, ((float)i + 0.5f) * inv, ((float)j + 0.5f) * inv);
            vsd_accum_sample(px, &r);
        }
}

extern "C" vsd_status vsd_cuda_shgrid_records(vsd_cuda *c, const vsd_krecord_grid *g, const vsd_kernel_data *kd,
                                              int lights, float *out, const vsd_cuda_progress *p, char *err,
                                              size_t errlen)
{
    const vsd_krecord_grid *dg;
    vsd_status st = vsd_cuda_put_with_kd(c, g, kd, &dg, err, errlen);
    if (st) return st;
    // records as "rows" of a one-wide image, in bands of 4096 records
    int count = g->record_count;
    return vsd_cuda_bands(c, count, 4096, p, "shgrid record pass", [&](int r0, int r1) {
        vsd_cuda_shgrid_records_kernel<<<(unsigned)((r1 - r0 + 127) / 128), 128, 0, c->stream>>>(dg, r0, r1, lights,
                                                                                                out);
    }, err, errlen);
}

extern "C" vsd_status vsd_cuda_shgrid_view(vsd_cuda *c, const vsd_krecord_grid *g, const vsd_kernel_data *kd, int n,
                                           double *accum, const vsd_cuda_progress *p, char *err, size_t errlen)
{
    const vsd_krecord_grid *dg;
    vsd_status st = vsd_cuda_put_with_kd(c, g, kd, &dg, err, errlen);
    if (st) return st;
    int w = kd->camera.width;
    return vsd_cuda_bands(c, kd->camera.height, 256, p, "ray marching", [&](int y0, int y1) {
        vsd_cuda_shgrid_view_kernel<<<vsd_cuda_grid(w, y1 - y0), vsd_cuda_block(), 0, c->stream>>>(dg, y0, y1, n, accum);
    }, err, errlen);
}
