/* record_grid_device.h — a record grid (kernel/kernel_record_grid.h) on the CUDA device of
 * ctx. Every array is resident and keyed by ctx->lighting_gen (a new frame always brings a
 * new lighting generation too), so a new camera uploads nothing but the structs. Used by
 * shgrid (its record pass and view) and constellation's cached shadows (view). */
#ifndef VSD_RECORD_GRID_DEVICE_H
#define VSD_RECORD_GRID_DEVICE_H
#include "method.h"
#include "kernel/kernel_record_grid.h"

/* d = g with its arrays on the device; with_records = 0 for a record pass, which writes
 * the records (so they are not uploaded) and reads the positions and directions. */
vsd_status vsd_record_grid_device(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int with_records,
                                  vsd_krecord_grid *d, char *err, size_t errlen);

/* The view pass (a vsd_device_pass_fn; kernel is the host vsd_krecord_grid). */
vsd_status vsd_record_grid_device_view(const vsd_frame_ctx *ctx, const void *kernel, int n, double *accum,
                                       const struct vsd_cuda_progress *progress, char *err, size_t errlen);

#endif
