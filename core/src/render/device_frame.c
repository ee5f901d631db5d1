#include "device_frame.h"
#include "kernel/kernel_lights.h"
#include <string.h>

uint64_t vsd_device_key(uint64_t gen, const void *host)
{
    return gen * 0x9E3779B97F4A7C15ull ^ (uint64_t)(uintptr_t)host;
}

vsd_status vsd_device_array(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, uint64_t gen, const void *host,
                            size_t bytes, const void **dev, char *err, size_t errlen)
{
    void *d = NULL;
    vsd_status st = VSD_OK;
    if (host && bytes) st = vsd_cuda_upload(ctx->cuda, slot, vsd_device_key(gen, host), host, bytes, &d, err, errlen);
    *dev = d;
    return st;
}

vsd_status vsd_device_volume(const vsd_frame_ctx *ctx, const vsd_volume *vol, vsd_kvolume *kv, int emission,
                             char *err, size_t errlen)
{
    int first_slot = emission ? VSD_SLOT_EMISSION_BRICKS : VSD_SLOT_DENSITY_BRICKS;
    size_t cells = (size_t)kv->dims[0] * kv->dims[1] * kv->dims[2];
    const void *d;
    vsd_status st;
    if (!vol || cells == 0) {
        kv->brick_slots = NULL;
        kv->voxels = NULL;
        kv->brick_max = NULL;
        return VSD_OK;
    }
    if ((st = vsd_device_array(ctx, (vsd_cuda_slot)(first_slot + 0), ctx->volume_gen, kv->brick_slots,
                               cells * sizeof(int32_t), &d, err, errlen)))
        return st;
    kv->brick_slots = d;
    if ((st = vsd_device_array(ctx, (vsd_cuda_slot)(first_slot + 1), ctx->volume_gen, kv->voxels,
                               (size_t)vol->brick_count * VSD_BRICK_VOXELS * sizeof(float), &d, err, errlen)))
        return st;
    kv->voxels = d;
    if ((st = vsd_device_array(ctx, (vsd_cuda_slot)(first_slot + 2), ctx->volume_gen, kv->brick_max,
                               cells * sizeof(float), &d, err, errlen)))
        return st;
    kv->brick_max = d;
    return VSD_OK;
}

vsd_status vsd_device_kernel_data(const vsd_frame_ctx *ctx, const vsd_kernel_data *kd, vsd_kernel_data *dev,
                                  char *err, size_t errlen)
{
    const vsd_kenv *e = &kd->env;
    const void *d;
    vsd_status st;
    *dev = *kd;
    if ((st = vsd_device_volume(ctx, ctx->density, &dev->density, 0, err, errlen)) ||
        (st = vsd_device_volume(ctx, ctx->emission, &dev->emission, 1, err, errlen)))
        return st;
    /* the map and its tables change only with the map (strength and rotation are in kd) */
    if ((st = vsd_device_array(ctx, VSD_SLOT_ENV_RGB, ctx->env_gen, e->rgb,
                               (size_t)e->width * e->height * 3 * sizeof(float), &d, err, errlen)))
        return st;
    dev->env.rgb = d;
    if ((st = vsd_device_array(ctx, VSD_SLOT_ENV_ROWS, ctx->env_gen, e->cdf_rows,
                               (size_t)(e->height + 1) * sizeof(float), &d, err, errlen)))
        return st;
    dev->env.cdf_rows = d;
    if ((st = vsd_device_array(ctx, VSD_SLOT_ENV_COLS, ctx->env_gen, e->cdf_cols,
                               (size_t)e->height * (e->width + 1) * sizeof(float), &d, err, errlen)))
        return st;
    dev->env.cdf_cols = d;
    if ((st = vsd_device_array(ctx, VSD_SLOT_LIGHTS, ctx->lighting_gen, kd->lights,
                               (size_t)kd->light_count * 8 * sizeof(float), &d, err, errlen)))
        return st;
    dev->lights = d;
    if ((st = vsd_device_array(ctx, VSD_SLOT_SCENE_LIGHTS, ctx->lighting_gen, kd->scene_lights,
                               (size_t)kd->scene_light_count * VSD_KLIGHT_FLOATS * sizeof(float), &d, err, errlen)))
        return st;
    dev->scene_lights = d;
    return VSD_OK;
}

size_t vsd_device_accum_bytes(int width, int height)
{
    return (size_t)width * (size_t)height * VSD_ACC_N * sizeof(double);
}

vsd_status vsd_device_accum(const vsd_frame_ctx *ctx, int width, int height, double **dev, char *err,
                            size_t errlen)
{
    void *d;
    vsd_status st = vsd_cuda_scratch(ctx->cuda, VSD_SLOT_ACCUM, 0, vsd_device_accum_bytes(width, height), 1, &d, err,
                                     errlen);
    *dev = d;
    return st;
}

vsd_status vsd_device_accum_collect(const vsd_frame_ctx *ctx, const double *dev, vsd_accum *acc, vsd_status st,
                                    char *err, size_t errlen)
{
    char ferr[256];
    vsd_status fst;
    if (st != VSD_OK && st != VSD_ERR_CANCELLED) return st;
    fst = vsd_cuda_download(ctx->cuda, acc->v, dev, vsd_device_accum_bytes(acc->width, acc->height), ferr,
                            sizeof ferr);
    return fst ? vsd_fail(fst, err, errlen, "%s", ferr) : st;
}

void vsd_device_progress(const vsd_frame_ctx *ctx, const char *stage, float base, float span,
                         vsd_cuda_progress *p)
{
    memset(p, 0, sizeof *p);
    p->fn = ctx->progress;
    p->user = ctx->user;
    p->stage = stage;
    p->base = base;
    p->span = span;
    p->cancel = ctx->cancel;
}

vsd_status vsd_device_run(const vsd_frame_ctx *ctx, const vsd_device_pass *pass, const void *m,
                          const vsd_kernel_data *kd, vsd_pass_args a, int items, void *out, size_t out_bytes,
                          float base, float span, char *err, size_t errlen)
{
    vsd_kernel_data dkd;
    vsd_cuda_progress progress;
    vsd_status st = vsd_device_kernel_data(ctx, kd, &dkd, err, errlen);
    if (st) return st;
    vsd_device_progress(ctx, pass->stage, base, span, &progress);
    return vsd_cuda_run_pass(ctx->cuda, pass, m, &dkd, a, items, out, out_bytes, &progress, err, errlen);
}
