/* device_pass.h — a pass a method runs on a device, described as data. The CUDA backend
 * (core/device/cuda) launches any such pass, its host emulation (tests/device_emulation)
 * runs it serially, and the CPU's stratified view pass (src/method/stratified.c) runs the
 * same per-sample function on tiles: so the backend knows no method, and a method brings
 * one descriptor per pass plus a three-line CUDA entry file in its own folder
 * (core/device/cuda/cuda_pass.cuh, VSD_CUDA_PIXEL_PASS / VSD_CUDA_ITEM_PASS).
 *
 * Two shapes:
 *   pixels  one thread per pixel over bands of image rows; samples [first, first + count)
 *           of every pixel are added, in that order, into the pixel's VSD_ACC_N double sums
 *           (kernel/kernel_accum.h) — the CPU's order, so both backends sum alike;
 *   items   one thread per item (a record, a view sub-sample) writing its own part of out. */
#ifndef VSD_DEVICE_PASS_H
#define VSD_DEVICE_PASS_H
#include <stddef.h>
#include "kernel/kernel_types.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct vsd_pass_args {
    int first, count; /* pixel passes: the samples of each pixel, [first, first + count) */
    int n;            /* the method's own parameter: n of the n x n strata, or a mode */
} vsd_pass_args;

/* One launch over rows (pixel passes) or items [b0, b1) on CUDA stream `stream`; dev_struct
 * is the method's kernel struct on the device (dev_kd when the pass reads only kd), width
 * the image width (the device kd is not readable from the host). */
typedef void (*vsd_cuda_band_fn)(void *stream, const void *dev_struct, const vsd_kernel_data *dev_kd, int width,
                                 int b0, int b1, vsd_pass_args a, void *out);

/* Called once per device array a pass reads: the emulation checks each lies in device
 * memory and holds `bytes` (a short upload or a host pointer is a bug it reports). */
typedef void (*vsd_pass_array_visit)(void *user, const void *ptr, size_t bytes, const char *name);

typedef struct vsd_device_pass {
    const char *stage;      /* progress stage and error context */
    int pixels;             /* 1: pixel pass, 0: item pass */
    int band;               /* rows or items per launch; progress and cancel between launches */
    size_t struct_bytes;    /* the method's kernel struct, copied per launch (0: kd only) */
    size_t kd_offset;       /* offsetof(struct, kd): the member that points at the scene's kd */
    /* The kernel functions of the pass, called with the struct (host or device arrays). */
    vsd_sample_result (*sample)(const void *m, int x, int y, int s, int n);
    void (*item)(const void *m, int i, int n, void *out);
    /* The device arrays the pass reads from m, as handed to the run (its kd member still the
     * host kd); NULL when the pass reads none but kd's. */
    void (*arrays)(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user);
    vsd_cuda_band_fn cuda;  /* VSD_CUDA_ENTRY(name): NULL in a build without CUDA */
} vsd_device_pass;

/* A method's CUDA entry (defined by VSD_CUDA_*_PASS in its <name>_cuda.cu), referenced
 * only in builds with CUDA, so a build without nvcc needs no stubs for it. */
#if defined(VSD_WITH_CUDA) && VSD_WITH_CUDA
#define VSD_CUDA_ENTRY_DECL(entry) \
    void entry(void *, const void *, const vsd_kernel_data *, int, int, int, vsd_pass_args, void *)
#define VSD_CUDA_ENTRY(entry) entry
#else
#define VSD_CUDA_ENTRY_DECL(entry) struct vsd_no_cuda_##entry
#define VSD_CUDA_ENTRY(entry) NULL
#endif

/* Sample s of the n x n strata of a pixel: the centre of stratum (s mod n, s div n), the
 * order src/method/stratified.c has always used. */
VSD_DEVICE void vsd_stratum(int s, int n, float *u, float *v)
{
    float inv = 1.0f / (float)n;
    *u = ((float)(s % n) + 0.5f) * inv;
    *v = ((float)(s / n) + 0.5f) * inv;
}

/* A CPU view pass's per-sample function (the hottest loop of a camera change): flatten
 * inlines every kernel function it calls, so the whole march is one body the compiler
 * schedules at once, and target_clones builds it twice, an AVX2 copy the loader picks
 * where the CPU has it (SSE4.1's roundss for floorf among its gains) and the x86-64
 * baseline anywhere else. No FMA: its contractions move the image by rounding, and that
 * clone measured slower. Element-wise IEEE operations in the same order: the same image.
 * lbl's camera change at 1280x720 on smoke128: 0.52 -> 0.43 s (issue 32, 2-core VM). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__CUDACC__)
#define VSD_CPU_VIEW_SAMPLE __attribute__((target_clones("avx2", "default"), flatten))
#else
#define VSD_CPU_VIEW_SAMPLE
#endif

/* The per-sample function of a stratified view pass over a kernel `pixel(m, x, y, u, v)`:
 * sample s of pixel (x, y) is the centre of stratum s of its n x n strata. */
#define VSD_STRATIFIED_SAMPLE(name, T, pixel)                                                \
    VSD_DEVICE vsd_sample_result name(const T *m, int x, int y, int s, int n)               \
    {                                                                                        \
        float u, v;                                                                          \
        vsd_stratum(s, n, &u, &v);                                                           \
        return pixel(m, x, y, u, v);                                                         \
    }

#ifdef __cplusplus
}
#endif
#endif
