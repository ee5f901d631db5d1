/* Method `raymarch`: the brute-force single-scattering baseline (raymarch_kernel.h).
 * Lighting preparation picks the K fixed environment directions; the view pass marches
 * n x n stratified rays per pixel (a box filter like the reference's, without noise).
 * Options: lights (K, default 256), step (world units, default half the smallest voxel),
 * pixel_samples (n, default 2). */
#include "src/render/method.h"
#include "src/render/env_lights.h"
#include "src/render/device_frame.h"
#include "raymarch_kernel.h"
#include <stdlib.h>

static const char *const raymarch_options[] = { "lights", "step", "pixel_samples", NULL };

typedef struct raymarch_state {
    float *lights;
    int count;
    int pixel_samples;
} raymarch_state;


static vsd_status raymarch_create(void **state, const vsd_scene *scene, char *err, size_t errlen)
{
    raymarch_state *s = calloc(1, sizeof *s);
    double k = vsd_scene_option_number(scene, "lights", 256);
    double ps = vsd_scene_option_number(scene, "pixel_samples", 2);
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    if (ps < 1 || ps > 16) {
        free(s);
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.pixel_samples: %g is out of range 1..16", ps);
    }
    s->pixel_samples = (int)ps;
    if (k < 1 || k > 65536) {
        free(s);
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.lights: %g is out of range 1..65536", k);
    }
    if (vsd_scene_option_number(scene, "step", 1.0) <= 0) {
        free(s);
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.step: must be > 0");
    }
    s->count = (int)k;
    *state = s;
    return VSD_OK;
}

static vsd_status raymarch_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    raymarch_state *s = state;
    free(s->lights);
    s->lights = malloc(sizeof(float) * 8 * (size_t)s->count);
    if (!s->lights) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d lights", s->count);
    vsd_env_importance_lights(&ctx->kd.env, s->count, s->lights);
    return VSD_OK;
}

static vsd_sample_result raymarch_sample(const void *kernel, int x, int y, float jx, float jy)
{
    return vsd_raymarch_pixel((const vsd_kernel_data *)kernel, x, y, jx, jy);
}

/* The view pass on the GPU: the scene's arrays (with the lights) resident on the device. */
static vsd_status raymarch_device(const vsd_frame_ctx *ctx, const void *kernel, int n, double *accum,
                                  const vsd_cuda_progress *progress, char *err, size_t errlen)
{
    vsd_kernel_data dkd;
    vsd_status st = vsd_device_kernel_data(ctx, (const vsd_kernel_data *)kernel, &dkd, err, errlen);
    return st ? st : vsd_cuda_raymarch(ctx->cuda, &dkd, n, accum, progress, err, errlen);
}

static vsd_status raymarch_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                                  char *err, size_t errlen)
{
    raymarch_state *s = state;
    ctx->kd.lights = s->lights;
    ctx->kd.light_count = s->count;
    ctx->kd.march_step = vsd_method_march_step(ctx, vsd_scene_option_number(ctx->scene, "step", 0.0));
    return vsd_method_render_stratified(ctx, fb, s->pixel_samples, raymarch_sample, raymarch_device, &ctx->kd,
                                        "ray marching", samples, err, errlen);
}

static void raymarch_destroy(void *state)
{
    raymarch_state *s = state;
    if (!s) return;
    free(s->lights);
    free(s);
}

const vsd_method vsd_method_raymarch = {
    "raymarch", raymarch_options, raymarch_create, NULL, raymarch_prepare_lighting, raymarch_render,
    raymarch_destroy,
};
