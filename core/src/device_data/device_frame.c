#include "device_frame.h"
#include "kernel/kernel_lights.h"
#include <string.h>
#include <xxhash.h>

uint64_t vsd_device_key(uint64_t gen, const void *host)
{
    return gen * 0x9E3779B97F4A7C15ull ^ (uint64_t)(uintptr_t)host;
}

/* The scene's slots: every method reads them, so they stay when the renderer changes method. */
/* Each volume's bricks have slots of their own (a part of a record-grid method reads its
 * volume as volume 0 without copying it again): [volume][density table, density bricks,
 * density maxima, emission table, emission bricks, emission maxima]. */
#define VOLUME_SLOTS(i)                                                                          \
    {{"volumes[" #i "] density brick table", VSD_CUDA_SCENE_SLOT},                               \
     {"volumes[" #i "] density bricks", VSD_CUDA_SCENE_SLOT},                                    \
     {"volumes[" #i "] density brick maxima", VSD_CUDA_SCENE_SLOT},                              \
     {"volumes[" #i "] emission brick table", VSD_CUDA_SCENE_SLOT},                              \
     {"volumes[" #i "] emission bricks", VSD_CUDA_SCENE_SLOT},                                   \
     {"volumes[" #i "] emission brick maxima", VSD_CUDA_SCENE_SLOT}}
static const vsd_cuda_slot_desc volume_slots[VSD_KMAX_VOLUMES][6] = {
    VOLUME_SLOTS(0),  VOLUME_SLOTS(1),  VOLUME_SLOTS(2),  VOLUME_SLOTS(3),  VOLUME_SLOTS(4),  VOLUME_SLOTS(5),
    VOLUME_SLOTS(6),  VOLUME_SLOTS(7),  VOLUME_SLOTS(8),  VOLUME_SLOTS(9),  VOLUME_SLOTS(10), VOLUME_SLOTS(11),
    VOLUME_SLOTS(12), VOLUME_SLOTS(13), VOLUME_SLOTS(14), VOLUME_SLOTS(15)};
#undef VOLUME_SLOTS
/* kd.volumes with device pointers, when the scene has several */
VSD_DEVICE_SCENE_SLOT(slot_volume_table, "volume table (kd.volumes)");
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

vsd_status vsd_device_content(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, const void *host, size_t bytes,
                              const void **dev, char *err, size_t errlen)
{
    /* never key 0, which always copies */
    return upload(ctx, slot, host && bytes ? XXH3_64bits(host, bytes) | 1u : 0, host, bytes, dev, err, errlen);
}

vsd_status vsd_device_scratch(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, size_t bytes, int zero, void **dev,
                              char *err, size_t errlen)
{
    claim(ctx, slot);
    return vsd_cuda_scratch(ctx->cuda, slot, 0, bytes, zero, dev, err, errlen);
}

/* Which of the scene's volumes vol is (its slots), 0 when it is none of them. */
static int volume_index(const vsd_frame_ctx *ctx, const vsd_volume *vol, int emission)
{
    int i, n = ctx->volume_count < VSD_KMAX_VOLUMES ? ctx->volume_count : VSD_KMAX_VOLUMES;
    for (i = 0; i < n; i++)
        if ((emission ? ctx->volume_emission[i] : ctx->volume_density[i]) == vol) return i;
    return 0;
}

vsd_status vsd_device_volume(const vsd_frame_ctx *ctx, const vsd_volume *vol, vsd_kvolume *kv, int emission,
                             char *err, size_t errlen)
{
    const vsd_cuda_slot_desc *slots = volume_slots[volume_index(ctx, vol, emission)] + (emission ? 3 : 0);
    vsd_cuda_slot bricks = &slots[0], voxels = &slots[1], maxima = &slots[2];
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

/* dev->volumes: every volume's bricks resident in its own slots, and the table of them
 * copied when its bytes change (a medium edit; a camera change copies nothing). */
static vsd_status device_volume_table(const vsd_frame_ctx *ctx, const vsd_kernel_data *kd, vsd_kernel_data *dev,
                                      char *err, size_t errlen)
{
    vsd_kobject table[VSD_KMAX_VOLUMES];
    const void *d;
    vsd_status st;
    int i, n = kd->volume_count;
    if (n <= 1 || !kd->volumes) {
        dev->volumes = NULL;
        return VSD_OK;
    }
    if (n > VSD_KMAX_VOLUMES || n != ctx->volume_count)
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "device volumes: %d volumes in the kernel data, %d in the frame", n,
                        ctx->volume_count);
    memset(table, 0, sizeof table);   /* the key hashes the bytes, padding included */
    for (i = 0; i < n; i++) {
        memcpy(&table[i], &kd->volumes[i], sizeof table[i]);
        if ((st = vsd_device_volume(ctx, ctx->volume_density[i], &table[i].density, 0, err, errlen)) ||
            (st = vsd_device_volume(ctx, ctx->volume_emission[i], &table[i].emission, 1, err, errlen)))
            return st;
    }
    if ((st = vsd_device_content(ctx, slot_volume_table, table, (size_t)n * sizeof table[0], &d, err, errlen)))
        return st;
    dev->volumes = d;
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
        (st = vsd_device_volume(ctx, ctx->emission, &dev->emission, 1, err, errlen)) ||
        (st = device_volume_table(ctx, kd, dev, err, errlen)))
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
