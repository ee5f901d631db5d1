/* The view pass of deterministic per-pixel methods (raymarch, shgrid): n x n stratified
 * rays per pixel over CPU tiles, accumulated and resolved into the passes. One loop, so the
 * pixel filter (a box, like the reference's) is the same for every such method. */
#include "method.h"
#include "accum.h"
#include "device_frame.h"
#include "device/cpu/cpu_tiles.h"

typedef struct stratified_pass {
    vsd_pixel_fn fn;
    const void *kernel;
    vsd_accum *acc;
    int n;
} stratified_pass;

static void stratified_tile(void *user, int x0, int y0, int x1, int y1)
{
    stratified_pass *p = user;
    int x, y, i, j;
    float inv = 1.0f / (float)p->n;
    for (y = y0; y < y1; y++)
        for (x = x0; x < x1; x++)
            for (j = 0; j < p->n; j++)
                for (i = 0; i < p->n; i++) {
                    vsd_sample_result res = p->fn(p->kernel, x, y, ((float)i + 0.5f) * inv, ((float)j + 0.5f) * inv);
                    vsd_accum_add(p->acc, x, y, &res);
                }
}

/* The GPU path: the device sums the same samples in the same order, then the host
 * resolves them exactly as after the CPU tiles. */
static vsd_status stratified_device(vsd_frame_ctx *ctx, vsd_accum *acc, int n, vsd_device_pass_fn device_fn,
                                    const void *kernel, const char *stage, char *err, size_t errlen)
{
    vsd_cuda_progress progress;
    double *dev;
    vsd_status st;
    if (!device_fn) return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "%s: no CUDA view pass", stage);
    st = vsd_device_accum(ctx, acc->width, acc->height, &dev, err, errlen);
    if (st) return st;
    vsd_device_progress(ctx, stage, 0.0f, 1.0f, &progress);
    st = device_fn(ctx, kernel, n, dev, &progress, err, errlen);
    return vsd_device_accum_collect(ctx, dev, acc, st, err, errlen);
}

vsd_status vsd_method_render_stratified(vsd_frame_ctx *ctx, vsd_framebuffer *fb, int n, vsd_pixel_fn fn,
                                        vsd_device_pass_fn device_fn, const void *kernel, const char *stage,
                                        int *samples, char *err, size_t errlen)
{
    vsd_accum acc;
    stratified_pass pass;
    vsd_tile_job job;
    vsd_status st = vsd_accum_init(&acc, fb->width, fb->height, err, errlen);
    if (st) return st;
    if (ctx->cuda) {
        st = stratified_device(ctx, &acc, n, device_fn, kernel, stage, err, errlen);
        if (!st || st == VSD_ERR_CANCELLED) vsd_accum_resolve(&acc, n * n, ctx->scene->film.transparent, fb);
        vsd_accum_free(&acc);
        *samples = n * n;
        return st;
    }
    pass.fn = fn;
    pass.kernel = kernel;
    pass.acc = &acc;
    pass.n = n;
    vsd_method_tile_job(&job, ctx, fb, stratified_tile, &pass, stage);
    st = vsd_cpu_run_tiles(&job);
    if (st == VSD_ERR_CANCELLED) vsd_fail(st, err, errlen, "render cancelled");
    vsd_accum_resolve(&acc, n * n, ctx->scene->film.transparent, fb);
    vsd_accum_free(&acc);
    *samples = n * n;
    return st;
}

float vsd_method_march_step(const vsd_frame_ctx *ctx, double option)
{
    float step = option > 0 ? (float)option
               : (ctx->kd.density.step > 0 ? ctx->kd.density.step : ctx->kd.emission.step);
    return step > 0 ? step : 0.01f;
}
