// cuda_pass.cuh — the generic CUDA kernels of device_pass.h, for a method's entry file.
// A method's <name>_cuda.cu is a few lines:
//     #include "device/cuda/cuda_pass.cuh"
//     #include "methods/<name>/<name>_kernel.h"
//     VSD_CUDA_PIXEL_PASS(vsd_cuda_<name>_view, vsd_k<name>, vsd_<name>_sample)
// which defines the extern "C" entry its vsd_device_pass names with VSD_CUDA_ENTRY.
#ifndef VSD_CUDA_PASS_CUH
#define VSD_CUDA_PASS_CUH
#include "cuda_internal.cuh"
#include "device/device_pass.h"

// One thread per pixel of rows [y0, y1): the pixel's samples in order into its sums.
template <typename T, typename F>
__global__ void vsd_cuda_pixel_kernel(const T *m, int width, int y0, int y1, vsd_pass_args a, double *accum)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = y0 + blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= width || y >= y1) return;
    double *px = accum + ((size_t)y * width + x) * VSD_ACC_N;
    for (int s = a.first; s < a.first + a.count; s++) {
        vsd_sample_result r = F::run(m, x, y, s, a.n);
        vsd_accum_sample(px, &r);
    }
}

// One thread per item of [i0, i1).
template <typename T, typename F>
__global__ void vsd_cuda_item_kernel(const T *m, int i0, int i1, vsd_pass_args a, void *out)
{
    int i = i0 + (int)(blockIdx.x * blockDim.x + threadIdx.x);
    if (i < i1) F::run(m, i, a.n, out);
}

// dev_struct is the method's struct, or the kd when the pass reads kd only (T = vsd_kernel_data).
#define VSD_CUDA_PIXEL_PASS(entry, T, fn)                                                                       \
    struct entry##_fn {                                                                                         \
        __device__ static vsd_sample_result run(const T *m, int x, int y, int s, int n) { return fn(m, x, y, s, n); } \
    };                                                                                                          \
    extern "C" void entry(void *stream, const void *dev_struct, const vsd_kernel_data *dev_kd, int width, int y0, \
                          int y1, vsd_pass_args a, void *out)                                                   \
    {                                                                                                           \
        (void)dev_kd;                                                                                           \
        vsd_cuda_pixel_kernel<T, entry##_fn><<<vsd_cuda_grid(width, y1 - y0), vsd_cuda_block(), 0,             \
                                               (cudaStream_t)stream>>>((const T *)dev_struct, width, y0, y1, a,  \
                                                                        (double *)out);                          \
    }

#define VSD_CUDA_ITEM_PASS(entry, T, fn)                                                                        \
    struct entry##_fn {                                                                                         \
        __device__ static void run(const T *m, int i, int n, void *out) { fn(m, i, n, out); }                   \
    };                                                                                                          \
    extern "C" void entry(void *stream, const void *dev_struct, const vsd_kernel_data *dev_kd, int width, int i0, \
                          int i1, vsd_pass_args a, void *out)                                                   \
    {                                                                                                           \
        (void)dev_kd;                                                                                           \
        (void)width;                                                                                            \
        vsd_cuda_item_kernel<T, entry##_fn><<<(unsigned)((i1 - i0 + 127) / 128), 128, 0, (cudaStream_t)stream>>>( \
            (const T *)dev_struct, i0, i1, a, out);                                                             \
    }

#endif
