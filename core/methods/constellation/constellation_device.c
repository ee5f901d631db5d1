#include "constellation_device.h"
#include "src/render/device_frame.h"

/* A distance map with its dense grid on the device; slots differ for density and emission. */
static vsd_status device_distmap(const vsd_frame_ctx *ctx, const vsd_kdistmap *m, int emission, vsd_kdistmap *d,
                                 char *err, size_t errlen)
{
    size_t cells = (size_t)m->dims[0] * m->dims[1] * m->dims[2];
    size_t voxels = (size_t)(m->dims[0] + 1) * (m->dims[1] + 1) * (m->dims[2] + 1);
    const void *p;
    vsd_status st;
    *d = *m;
    if ((st = vsd_device_array(ctx, emission ? VSD_SLOT_CST_DM_EMISSION : VSD_SLOT_CST_DM_DENSITY, ctx->frame_gen,
                               m->skip, cells, &p, err, errlen)))
        return st;
    d->skip = p;
    if ((st = vsd_device_array(ctx, emission ? VSD_SLOT_CST_FIELD_EMISSION : VSD_SLOT_CST_FIELD_DENSITY,
                               ctx->frame_gen, m->field, voxels * sizeof(float), &p, err, errlen)))
        return st;
    d->field = p;
    if ((st = vsd_device_array(ctx, emission ? VSD_SLOT_CST_CODE_EMISSION : VSD_SLOT_CST_CODE_DENSITY,
                               ctx->frame_gen, m->shadow_code, cells, &p, err, errlen)))
        return st;
    d->shadow_code = p;
    return VSD_OK;
}

vsd_status vsd_cst_device_render(const vsd_frame_ctx *ctx, const vsd_kconstellation *kc, int use_mask, vsd_accum *acc,
                                 char *err, size_t errlen)
{
    vsd_kernel_data dkd;
    vsd_kconstellation dkc = *kc;
    vsd_cuda_progress progress;
    double *sums;
    int n2 = kc->pixel_samples * kc->pixel_samples;
    vsd_status st = vsd_device_kernel_data(ctx, kc->kd, &dkd, err, errlen);
    if (!st) st = device_distmap(ctx, &kc->dm_density, 0, &dkc.dm_density, err, errlen);
    if (!st) st = device_distmap(ctx, &kc->dm_emission, 1, &dkc.dm_emission, err, errlen);
    if (st) return st;
    dkc.first = NULL;
    if (use_mask) {
        void *first;
        st = vsd_cuda_scratch(ctx->cuda, VSD_SLOT_CST_FIRST, 0,
                              sizeof(int32_t) * (size_t)acc->width * acc->height * n2, 0, &first, err, errlen);
        if (st) return st;
        vsd_device_progress(ctx, "validity mask", 0.0f, 0.05f, &progress);
        if ((st = vsd_cuda_constellation_mask(ctx->cuda, &dkc, &dkd, first, &progress, err, errlen))) return st;
        dkc.first = first;
    }
    if ((st = vsd_device_accum(ctx, acc->width, acc->height, &sums, err, errlen))) return st;
    vsd_device_progress(ctx, "lighting", use_mask ? 0.05f : 0.0f, use_mask ? 0.95f : 1.0f, &progress);
    st = vsd_cuda_constellation_light(ctx->cuda, &dkc, &dkd, sums, &progress, err, errlen);
    return vsd_device_accum_collect(ctx, sums, acc, st, err, errlen);
}
