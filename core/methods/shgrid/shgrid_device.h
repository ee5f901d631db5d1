/* shgrid_device.h — shgrid on the CUDA device of ctx: the record pass (the paper's
 * per-frame GPU work; records are copied back so host-side steps such as the triple
 * product keep working); the view pass is the record grid's (src/device_data/record_grid_device.h). Every
 * array of the grid is resident and keyed by ctx->lighting_gen (a new frame always brings
 * a new lighting generation too), so a new camera uploads nothing but the structs. */
#ifndef VSD_SHGRID_DEVICE_H
#define VSD_SHGRID_DEVICE_H
#include "src/method/method.h"
#include "shgrid_kernel.h"

/* The record pass of grid g (host arrays) into host_out: SH records (record_count x
 * stride floats), or with lights != 0 the transmittance toward each extracted light
 * (record_count x light_count floats). */
vsd_status vsd_shgrid_device_records(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int lights, float *host_out,
                                     char *err, size_t errlen);

#endif
