#include "constellation_device.h"
#include "src/device_data/device_frame.h"
#include <stddef.h>

/* The constellation's own resident slots (its cached shadows' record grid has its own). */
VSD_DEVICE_SLOT(cst_dm_density, "constellation distance map (density)");
VSD_DEVICE_SLOT(cst_dm_emission, "constellation distance map (emission)");
VSD_DEVICE_SLOT(cst_field_density, "constellation distance field (density)");
VSD_DEVICE_SLOT(cst_field_emission, "constellation distance field (emission)");
VSD_DEVICE_SLOT(cst_code_density, "constellation shadow codes (density)");
VSD_DEVICE_SLOT(cst_code_emission, "constellation shadow codes (emission)");
VSD_DEVICE_SLOT(cst_first, "constellation validity mask (first shell per view ray)");

/* A distance map with its dense grid on the device; slots differ for density and emission. */
static vsd_status device_distmap(const vsd_frame_ctx *ctx, const vsd_kdistmap *m, int emission, vsd_kdistmap *d,
                                 char *err, size_t errlen)
{
    size_t cells = (size_t)m->dims[0] * m->dims[1] * m->dims[2];
    size_t voxels = (size_t)(m->dims[0] + 1) * (m->dims[1] + 1) * (m->dims[2] + 1);
    const void *p;
    vsd_status st;
    *d = *m;
    if ((st = vsd_device_array(ctx, emission ? cst_dm_emission : cst_dm_density, ctx->frame_gen,
                               m->skip, cells, &p, err, errlen)))
        return st;
    d->skip = p;
    if ((st = vsd_device_array(ctx, emission ? cst_field_emission : cst_field_density,
                               ctx->frame_gen, m->field, voxels * sizeof(float), &p, err, errlen)))
        return st;
    d->field = p;
    if ((st = vsd_device_array(ctx, emission ? cst_code_emission : cst_code_density,
                               ctx->frame_gen, m->shadow_code, cells, &p, err, errlen)))
        return st;
    d->shadow_code = p;
    return VSD_OK;
}

static void distmap_arrays(const vsd_kdistmap *m, vsd_pass_array_visit visit, void *user, const char *skip,
                           const char *field, const char *code)
{
    size_t cells = (size_t)m->dims[0] * m->dims[1] * m->dims[2];
    size_t voxels = (size_t)(m->dims[0] + 1) * (m->dims[1] + 1) * (m->dims[2] + 1);
    if (m->skip) visit(user, m->skip, cells, skip);
    if (m->field) {
        visit(user, m->field, voxels * sizeof(float), field);
        visit(user, m->shadow_code, cells, code);
    }
}

static void cst_arrays(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    const vsd_kconstellation *kc = m;
    (void)a;
    distmap_arrays(&kc->dm_density, visit, user, "dm_density.skip", "dm_density.field", "dm_density.shadow_code");
    distmap_arrays(&kc->dm_emission, visit, user, "dm_emission.skip", "dm_emission.field", "dm_emission.shadow_code");
}

static void light_arrays(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    const vsd_kconstellation *kc = m;
    cst_arrays(m, a, visit, user);
    if (kc->first)
        visit(user, kc->first, sizeof(int32_t) * (size_t)kc->kd->camera.width * (size_t)kc->kd->camera.height * (size_t)a.count,
              "first");
}

static void mask_item(const void *m, int i, int n, void *out)
{
    vsd_cst_mask_item((const vsd_kconstellation *)m, i, n, out);
}

static vsd_sample_result light_sample(const void *m, int x, int y, int s, int n)
{
    return vsd_cst_pass_sample((const vsd_kconstellation *)m, x, y, s, n);
}

/* The validity mask, one thread per view sub-sample, and the lighting pass, one per pixel
 * (constellation_cuda.cu). */
VSD_CUDA_ENTRY_DECL(vsd_cuda_constellation_mask);
VSD_CUDA_ENTRY_DECL(vsd_cuda_constellation_light);
static const vsd_device_pass cst_mask_pass = {
    "validity mask", 0, 1 << 18, sizeof(vsd_kconstellation), offsetof(vsd_kconstellation, kd), NULL, mask_item,
    cst_arrays, VSD_CUDA_ENTRY(vsd_cuda_constellation_mask),
};
static const vsd_device_pass cst_light_pass = {
    "lighting", 1, 128, sizeof(vsd_kconstellation), offsetof(vsd_kconstellation, kd), light_sample, NULL,
    light_arrays, VSD_CUDA_ENTRY(vsd_cuda_constellation_light),
};

vsd_status vsd_cst_device_render(const vsd_frame_ctx *ctx, const vsd_kconstellation *kc, int use_mask, vsd_accum *acc,
                                 char *err, size_t errlen)
{
    vsd_kconstellation dkc = *kc;
    double *sums;
    int n2 = kc->pixel_samples * kc->pixel_samples;
    vsd_pass_args a = {0, n2, 0};
    vsd_status st = device_distmap(ctx, &kc->dm_density, 0, &dkc.dm_density, err, errlen);
    if (!st) st = device_distmap(ctx, &kc->dm_emission, 1, &dkc.dm_emission, err, errlen);
    if (st) return st;
    dkc.first = NULL;
    if (use_mask) {
        size_t items = (size_t)acc->width * acc->height * n2;
        void *first;
        if (items > 0x7fffffff)
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "validity mask: %zu view rays exceed the device pass's limit",
                            items);
        if ((st = vsd_device_scratch(ctx, cst_first, sizeof(int32_t) * items, 0, &first, err, errlen)) ||
            (st = vsd_device_run(ctx, &cst_mask_pass, &dkc, kc->kd, a, (int)items, first, sizeof(int32_t) * items,
                                 0.0f, 0.05f, err, errlen)))
            return st;
        dkc.first = first;
    }
    if ((st = vsd_device_accum(ctx, acc->width, acc->height, &sums, err, errlen))) return st;
    st = vsd_device_run(ctx, &cst_light_pass, &dkc, kc->kd, a, 0, sums, vsd_device_accum_bytes(acc->width, acc->height),
                        use_mask ? 0.05f : 0.0f, use_mask ? 0.95f : 1.0f, err, errlen);
    return vsd_device_accum_collect(ctx, sums, acc, st, err, errlen);
}
