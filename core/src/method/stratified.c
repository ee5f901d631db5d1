/* The view pass of deterministic per-pixel methods (raymarch, the record grids): n x n
 * stratified rays per pixel, on CPU tiles or as a device pass, accumulated and resolved
 * into the passes. One loop, so the pixel filter (a box, like the reference's) is the same
 * for every such method and both backends. */
#include "method.h"
#include "src/render/accum.h"
#include "src/device_data/device_frame.h"
#include "device/cpu/cpu_tiles.h"
#include "device/device_pass.h"
#include <stdio.h>
#include <string.h>

typedef struct stratified_pass {
    const vsd_device_pass *pass;
    const void *kernel;
    vsd_accum *acc;
    int n;
} stratified_pass;

static void stratified_tile(void *user, int x0, int y0, int x1, int y1)
{
    stratified_pass *p = user;
    int x, y, s;
    for (y = y0; y < y1; y++)
        for (x = x0; x < x1; x++)
            for (s = 0; s < p->n * p->n; s++) {
                vsd_sample_result res = p->pass->sample(p->kernel, x, y, s, p->n);
                vsd_accum_add(p->acc, x, y, &res);
            }
}

/* The GPU path: the device sums the same samples in the same order, then the host
 * resolves them exactly as after the CPU tiles. */
static vsd_status stratified_device(vsd_frame_ctx *ctx, vsd_accum *acc, int n, const vsd_device_pass *pass,
                                    vsd_device_struct_fn to_device, const void *kernel, char *err, size_t errlen)
{
    _Alignas(64) unsigned char dev[VSD_DEVICE_STRUCT_MAX];
    const void *m = NULL;
    const vsd_kernel_data *kd = kernel;
    vsd_pass_args a = {0, n * n, n};
    double *sums;
    vsd_status st;
    if (pass->struct_bytes) {
        if (!to_device || pass->struct_bytes > sizeof dev)
            return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "%s: no device struct for the pass", pass->stage);
        if ((st = to_device(ctx, kernel, dev, err, errlen))) return st;
        memcpy(&kd, (const unsigned char *)kernel + pass->kd_offset, sizeof kd);
        m = dev;
    }
    if ((st = vsd_device_accum(ctx, acc->width, acc->height, &sums, err, errlen))) return st;
    st = vsd_device_run(ctx, pass, m, kd, a, 0, sums, vsd_device_accum_bytes(acc->width, acc->height), 0.0f, 1.0f,
                        err, errlen);
    return vsd_device_accum_collect(ctx, sums, acc, st, err, errlen);
}

vsd_status vsd_method_render_stratified(vsd_frame_ctx *ctx, vsd_framebuffer *fb, int n, const vsd_device_pass *pass,
                                        vsd_device_struct_fn to_device, const void *kernel, int *samples, char *err,
                                        size_t errlen)
{
    return vsd_method_render_view(ctx, fb, n, NULL, pass, to_device, kernel, samples, err, errlen);
}

vsd_status vsd_method_render_view(vsd_frame_ctx *ctx, vsd_framebuffer *fb, int n, const vsd_view_sampling *vs,
                                  const vsd_device_pass *pass, vsd_device_struct_fn to_device, const void *kernel,
                                  int *samples, char *err, size_t errlen)
{
    vsd_accum acc;
    stratified_pass sp;
    vsd_tile_job job;
    /* vs with an automatic spacing resolved (1 = trace every pixel) */
    vsd_view_sampling eff = {1, vs ? vs->threshold : 0.0};
    const int device = ctx->cuda && pass->cuda;
    vsd_status st;
    if (vs) eff.spacing = vs->spacing ? vs->spacing : vsd_view_auto_spacing(ctx);
    if (!device && eff.spacing > 1) {
        /* the adaptive view resolves the film itself and reads back only the sums it wrote */
        int permille = 0;
        if ((st = vsd_accum_borrow(&acc, ctx->accum_store, fb->width, fb->height, err, errlen))) return st;
        st = vsd_adaptive_view(ctx, &acc, fb, n, &eff, pass, kernel, &permille, err, errlen);
        if (ctx->info && ctx->info_len) {
            size_t used = strlen(ctx->info);
            if (used < ctx->info_len)
                snprintf(ctx->info + used, ctx->info_len - used, "%sview_spacing=%d view_traced=%.3f", used ? " " : "",
                         eff.spacing, permille / 1000.0);
        }
        /* a view stopped half way leaves no pixels of the last one (the film is not cleared
         * before a render: renderer.c) */
        if (st) vsd_framebuffer_clear(fb);
    } else {
        if ((st = vsd_accum_init(&acc, ctx->accum_store, ctx->threads, fb->width, fb->height, err, errlen))) return st;
        if (device) {
            st = stratified_device(ctx, &acc, n, pass, to_device, kernel, err, errlen);
        } else {
            sp.pass = pass;
            sp.kernel = kernel;
            sp.acc = &acc;
            sp.n = n;
            vsd_method_tile_job(&job, ctx, fb, stratified_tile, &sp, pass->stage);
            st = vsd_cpu_run_tiles(&job);
            if (st == VSD_ERR_CANCELLED) vsd_fail(st, err, errlen, "render cancelled");
        }
        /* a cancelled render still resolves the tiles or bands it finished */
        if (!st || st == VSD_ERR_CANCELLED)
            vsd_accum_resolve(&acc, n * n, ctx->scene->film.transparent, ctx->threads, fb);
        else
            vsd_framebuffer_clear(fb);
    }
    vsd_accum_free(&acc);
    *samples = n * n;
    return st;
}

float vsd_kd_march_step(const vsd_kernel_data *kd, double option)
{
    float step = option > 0 ? (float)option : (kd->density.step > 0 ? kd->density.step : kd->emission.step);
    /* several volumes: the finest of them sets the step, so none is undersampled */
    for (int i = 1; option <= 0 && i < kd->volume_count; i++) {
        const vsd_kobject *o = &kd->volumes[i];
        float s = o->density.step > 0 ? o->density.step : o->emission.step;
        if (s > 0 && (!(step > 0) || s < step)) step = s;
    }
    return step > 0 ? step : 0.01f;
}

float vsd_method_march_step(const vsd_frame_ctx *ctx, double option)
{
    return vsd_kd_march_step(&ctx->kd, option);
}
