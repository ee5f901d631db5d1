#include "shgrid_device.h"
#include "src/render/device_frame.h"
#include "src/render/record_grid_device.h"

vsd_status vsd_shgrid_device_records(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int lights, float *host_out,
                                     char *err, size_t errlen)
{
    vsd_krecord_grid d;
    vsd_kernel_data dkd;
    vsd_cuda_progress progress;
    size_t floats = (size_t)g->record_count * (size_t)(lights ? g->light_count : g->stride);
    void *out;
    vsd_status st;
    if (floats == 0) return VSD_OK;
    if ((st = vsd_device_kernel_data(ctx, g->kd, &dkd, err, errlen)) ||
        (st = vsd_record_grid_device(ctx, g, 0, &d, err, errlen)) ||
        (st = vsd_cuda_scratch(ctx->cuda, lights ? VSD_SLOT_SH_LIGHT_TRANS : VSD_SLOT_SH_RECORDS, 0,
                               floats * sizeof(float), 0, &out, err, errlen)))
        return st;
    vsd_device_progress(ctx, lights ? "shgrid light records" : "record grid", 0.0f, 1.0f, &progress);
    if ((st = vsd_cuda_shgrid_records(ctx->cuda, &d, &dkd, lights, out, &progress, err, errlen))) return st;
    return vsd_cuda_download(ctx->cuda, host_out, out, floats * sizeof(float), err, errlen);
}

