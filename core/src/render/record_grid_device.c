/* The record grid on the CUDA device (record_grid_device.h). */
#include "record_grid_device.h"
#include "device_frame.h"

/* One array of the grid on the device (NULL stays NULL). At render time the arrays are
 * final for the lighting generation and stay resident; during the prepare stages shgrid.c
 * still rewrites some in place (the HEALPix radiance, the environment SH, the extracted
 * lights) between record passes of one generation, so record passes always copy. */
static vsd_status put(const vsd_frame_ctx *ctx, int record_pass, vsd_cuda_slot slot, const void *host, size_t bytes,
                      const void **dev, char *err, size_t errlen)
{
    void *d = NULL;
    vsd_status st = VSD_OK;
    if (!record_pass) return vsd_device_array(ctx, slot, ctx->lighting_gen, host, bytes, dev, err, errlen);
    if (host && bytes) st = vsd_cuda_upload(ctx->cuda, slot, 0, host, bytes, &d, err, errlen);
    *dev = d;
    return st;
}

vsd_status vsd_record_grid_device(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int with_records, vsd_krecord_grid *d,
                              char *err, size_t errlen)
{
    size_t cells = (size_t)g->res[0] * g->res[1] * g->res[2], recs = (size_t)g->record_count;
    size_t dirs = (size_t)g->dir_count, n2 = (size_t)g->n2, lights = (size_t)g->light_count;
    const void *p;
    vsd_status st;
    *d = *g;
#define PUT(field, slot, bytes) \
    do { if ((st = put(ctx, !with_records, slot, g->field, bytes, &p, err, errlen))) return st; d->field = p; } while (0)
    PUT(cell_record, VSD_SLOT_SH_CELLS, cells * sizeof(int32_t));
    PUT(light, VSD_SLOT_SH_LIGHT, 3 * n2 * sizeof(float));
    PUT(lights, VSD_SLOT_SH_LIGHTS, lights * 8 * sizeof(float));
    if (with_records) {
        /* the view pass reads the records, not what made them */
        PUT(records, VSD_SLOT_SH_RECORDS, recs * (size_t)g->stride * sizeof(float));
        PUT(light_trans, VSD_SLOT_SH_LIGHT_TRANS, recs * lights * sizeof(float));
        d->record_pos = d->dirs = d->basis = d->dir_radiance = NULL;
    } else {
        PUT(record_pos, VSD_SLOT_SH_POS, recs * 4 * sizeof(float));
        PUT(dirs, VSD_SLOT_SH_DIRS, dirs * 4 * sizeof(float));
        PUT(basis, VSD_SLOT_SH_BASIS, dirs * n2 * sizeof(float));
        PUT(dir_radiance, VSD_SLOT_SH_RADIANCE, dirs * 4 * sizeof(float));
        d->records = NULL;
        d->light_trans = NULL;
    }
#undef PUT
    return VSD_OK;
}

vsd_status vsd_record_grid_device_view(const vsd_frame_ctx *ctx, const void *kernel, int n, double *accum,
                                  const struct vsd_cuda_progress *progress, char *err, size_t errlen)
{
    const vsd_krecord_grid *g = kernel;
    vsd_krecord_grid d;
    vsd_kernel_data dkd;
    vsd_status st;
    if ((st = vsd_device_kernel_data(ctx, g->kd, &dkd, err, errlen)) ||
        (st = vsd_record_grid_device(ctx, g, 1, &d, err, errlen)))
        return st;
    return vsd_cuda_shgrid_view(ctx->cuda, &d, &dkd, n, accum, progress, err, errlen);
}
