#include "shgrid_device.h"
#include "src/device_data/device_frame.h"
#include "src/device_data/record_grid_device.h"
#include <stddef.h>

static void record_item(const void *g, int i, int lights, void *out)
{
    vsd_shgrid_record_item((const vsd_krecord_grid *)g, i, lights, out);
}

static void record_arrays(const void *g, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    vsd_record_grid_arrays(g, 0, a.n, visit, user);
}

/* One thread per record (shgrid_cuda.cu); a.n = 1 for the pass toward the lights. */
VSD_CUDA_ENTRY_DECL(vsd_cuda_shgrid_records);
static const vsd_device_pass shgrid_record_pass = {
    "record grid", 0, 4096, sizeof(vsd_krecord_grid), offsetof(vsd_krecord_grid, kd), NULL, record_item,
    record_arrays, VSD_CUDA_ENTRY(vsd_cuda_shgrid_records),
};

vsd_status vsd_shgrid_device_records(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int lights, float *host_out,
                                     char *err, size_t errlen)
{
    vsd_krecord_grid d;
    vsd_pass_args a = {0, 0, lights};
    size_t bytes = sizeof(float) * (size_t)g->record_count * (size_t)(lights ? g->light_count : g->stride);
    void *out;
    vsd_status st;
    if (bytes == 0) return VSD_OK;
    if ((st = vsd_record_grid_device(ctx, g, 0, &d, err, errlen)) ||
        (st = vsd_record_grid_output(ctx, lights, bytes, &out, err, errlen)) ||
        (st = vsd_device_run(ctx, &shgrid_record_pass, &d, g->kd, a, g->record_count, out, bytes, 0.0f, 1.0f, err,
                             errlen)))
        return st;
    return vsd_cuda_download(ctx->cuda, host_out, out, bytes, err, errlen);
}
