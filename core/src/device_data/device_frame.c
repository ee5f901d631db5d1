#include "device_frame.h"
#include "kernel/kernel_lights.h"
#include <string.h>

uint64_t vsd_device_key(uint64_t gen, const void *host)
{
    return gen * 0x9E3779B97F4A7C15ull ^ (uint64_t)(uintptr_t)host;
}

/* The scene's slots: every method reads them, so they stay when the renderer changes method. */
VSD_DEVICE_SCENE_SLOT(slot_density_bricks, "density brick table");
VSD_DEVICE_SCENE_SLOT(slot_density_voxels, "density bricks");
VSD_DEVICE_SCENE_SLOT(slot_density_max, "density brick maxima");
VSD_DEVICE_SCENE_SLOT(slot_emission_bricks, "emission brick table");
VSD_DEVICE_SCENE_SLOT(slot_emission_voxels, "emission bricks");
VSD_DEVICE_SCENE_SLOT(slot_emission_max, "emission brick maxima");
VSD_DEVICE_SCENE_SLOT(slot_env_rgb, "environment map");
VSD_DEVICE_SCENE_SLOT(slot_env_rows, "environment row CDF");
VSD_DEVICE_SCENE_SLOT(slot_env_cols, "environment column CDFs");
VSD_DEVICE_SCENE_SLOT(slot_lights, "lights (kd.lights)");
VSD_DEVICE_SCENE_SLOT(slot_scene_lights, "scene lights (kd.scene_lights)");
VSD_DEVICE_SCENE_SLOT(slot_accum, "per-pixel sums");

/* Names ctx's method to the backend, which frees the method slots when it changes
 * (cuda_backend.h): before a method slot is used, and before every device pass, so that a
 * method without slots of its own does not keep the previous method's either. */
static void name_method(const vsd_frame_ctx *ctx)
{
    if (ctx->scene) vsd_cuda_set_method(ctx->cuda, ctx->scene->render.method);
}

static void claim(const vsd_frame_ctx *ctx, vsd_cuda_slot slot)
{
    if (slot->kind == VSD_CUDA_METHOD_SLOT) name_method(ctx);
}

static vsd_status upload(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, uint64_t key, const void *host, size_t bytes,
                         const void **dev, char *err, size_t errlen)
{
    void *d = NULL;
    vsd_status st = VSD_OK;
    if (host && bytes) {
        claim(ctx, slot);
        st = vsd_cuda_upload(ctx->cuda, slot, key, host, bytes, &d, err, errlen);
    }
    *dev = d;
    return st;
}

vsd_status vsd_device_array(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, uint64_t gen, const void *host,
                            size_t bytes, const void **dev, char *err, size_t errlen)
{
    return upload(ctx, slot, vsd_device_key(gen, host), host, bytes, dev, err, errlen);
}

vsd_status vsd_device_copy(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, const void *host, size_t bytes,
                           const void **dev, char *err, size_t errlen)
{
    return upload(ctx, slot, 0, host, bytes, dev, err, errlen);
}

vsd_status vsd_device_scratch(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, size_t bytes, int zero, void **dev,
                              char *err, size_t errlen)
{
    claim(ctx, slot);
    return vsd_cuda_scratch(ctx->cuda, slot, 0, bytes, zero, dev, err, errlen);
}

vsd_status vsd_device_volume(const vsd_frame_ctx *ctx, const vsd_volume *vol, vsd_kvolume *kv, int emission,
                             char *err, size_t errlen)
{
    vsd_cuda_slot bricks = emission ? slot_emission_bricks : slot_density_bricks;
    vsd_cuda_slot voxels = emission ? slot_emission_voxels : slot_density_voxels;
    vsd_cuda_slot maxima = emission ? slot_emission_max : slot_density_max;
    size_t cells = (size_t)kv->dims[0] * kv->dims[1] * kv->dims[2];
    const void *d;
    vsd_status st;
    if (!vol || cells == 0) {
        kv->brick_slots = NULL;
        kv->voxels = NULL;
        kv->brick_max = NULL;
        return VSD_OK;
    }
    if ((st = vsd_device_array(ctx, bricks, ctx->volume_gen, kv->brick_slots,
                               cells * sizeof(int32_t), &d, err, errlen)))
        return st;
    kv->brick_slots = d;
    if ((st = vsd_device_array(ctx, voxels, ctx->volume_gen, kv->voxels,
                               (size_t)vol->brick_count * VSD_BRICK_VOXELS * sizeof(float), &d, err, errlen)))
        return st;
    kv->voxels = d;
    if ((st = vsd_device_array(ctx, maxima, ctx->volume_gen, kv->brick_max,
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
    if ((st = vsd_device_array(ctx, slot_env_rgb, ctx->env_gen, e->rgb,
                               (size_t)e->width * e->height * 3 * sizeof(float), &d, err, errlen)))
        return st;
    dev->env.rgb = d;
    if ((st = vsd_device_array(ctx, slot_env_rows, ctx->env_gen, e->cdf_rows,
                               (size_t)(e->height + 1) * sizeof(float), &d, err, errlen)))
        return st;
    dev->env.cdf_rows = d;
    if ((st = vsd_device_array(ctx, slot_env_cols, ctx->env_gen, e->cdf_cols,
                               (size_t)e->height * (e->width + 1) * sizeof(float), &d, err, errlen)))
        return st;
    dev->env.cdf_cols = d;
    if ((st = vsd_device_array(ctx, slot_lights, ctx->lighting_gen, kd->lights,
                               (size_t)kd->light_count * 8 * sizeof(float), &d, err, errlen)))
        return st;
    dev->lights = d;
    if ((st = vsd_device_array(ctx, slot_scene_lights, ctx->lighting_gen, kd->scene_lights,
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
    vsd_status st = vsd_device_scratch(ctx, slot_accum, vsd_device_accum_bytes(width, height), 1, &d, err, errlen);
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
    vsd_status st;
    name_method(ctx);
    st = vsd_device_kernel_data(ctx, kd, &dkd, err, errlen);
    if (st) return st;
    vsd_device_progress(ctx, pass->stage, base, span, &progress);
    return vsd_cuda_run_pass(ctx->cuda, pass, m, &dkd, a, items, out, out_bytes, &progress, err, errlen);
}
