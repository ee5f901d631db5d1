/* shgrid_device.h — shgrid on the CUDA device of ctx: the record pass (the paper's
 * per-frame GPU work; records are copied back so host-side steps such as the triple
 * product keep working) and the view pass, over the kernels of shgrid_kernel.h. Every
 * array of the grid is resident and keyed by ctx->lighting_gen (a new frame always brings
 * a new lighting generation too), so a new camera uploads nothing but the structs. */
#ifndef VSD_SHGRID_DEVICE_H
#define VSD_SHGRID_DEVICE_H
#include "src/render/method.h"
#include "shgrid_kernel.h"

/* The record pass of grid g (host arrays) into host_out: SH records (record_count x
 * stride floats), or with lights != 0 the transmittance toward each extracted light
 * (record_count x light_count floats). */
vsd_status vsd_shgrid_device_records(const vsd_frame_ctx *ctx, const vsd_kshgrid *g, int lights, float *host_out,
                                     char *err, size_t errlen);

/* The view pass (a vsd_device_pass_fn; kernel is the host vsd_kshgrid). */
vsd_status vsd_shgrid_device_view(const vsd_frame_ctx *ctx, const void *kernel, int n, double *accum,
                                  const struct vsd_cuda_progress *progress, char *err, size_t errlen);

#endif
