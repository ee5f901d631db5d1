/* Method `raymarch`: the brute-force single-scattering baseline (raymarch_kernel.h).
 * Lighting preparation picks the K fixed environment directions; the view pass marches
 * n x n stratified rays per pixel (a box filter like the reference's, without noise).
 * Options: lights (K, default 256), step (world units, default half the smallest voxel),
 * pixel_samples (n, default 1), early_termination (default 1e-3). */
#include "src/method/method.h"
#include "src/lighting/env_importance_lights.h"
#include "raymarch_kernel.h"
#include <stddef.h>
#include <stdlib.h>

typedef struct raymarch_options {
    int lights, pixel_samples;
    double step, early_termination;
} raymarch_options;

static const vsd_option_spec raymarch_option_rows[] = {
    {"lights", VSD_OPT_INT, 1, 65536, 256, NULL,
     "K fixed environment directions (importance-sampled) each step's shadow rays go to",
     offsetof(raymarch_options, lights), 0, NULL, NULL},
    {"step", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "view and shadow march step, world units (0 = half the smallest voxel)",
     offsetof(raymarch_options, step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    VSD_OPTION_PIXEL_SAMPLES(raymarch_options),
    VSD_OPTION_EARLY_TERMINATION(raymarch_options, "view ray"),
};

typedef struct raymarch_state {
    raymarch_options opt;
    float *lights;
} raymarch_state;

static vsd_status raymarch_create(void **state, const vsd_scene *scene, const void *options, char *err,
                                  size_t errlen)
{
    raymarch_state *s = calloc(1, sizeof *s);
    (void)scene;
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *(const raymarch_options *)options;
    *state = s;
    return VSD_OK;
}

static vsd_status raymarch_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    raymarch_state *s = state;
    free(s->lights);
    s->lights = malloc(sizeof(float) * 8 * (size_t)s->opt.lights);
    if (!s->lights) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d lights", s->opt.lights);
    vsd_env_importance_lights(&ctx->kd.env, s->opt.lights, s->lights);
    return VSD_OK;
}

static vsd_sample_result raymarch_sample(const void *kd, int x, int y, int s, int n)
{
    return vsd_raymarch_pass_sample((const vsd_kernel_data *)kd, x, y, s, n);
}

/* The view pass, on the CPU or the GPU (raymarch_cuda.cu); it reads only the scene's kd. */
VSD_CUDA_ENTRY_DECL(vsd_cuda_raymarch_view);
static const vsd_device_pass raymarch_view_pass = {
    "ray marching", 1, 64, 0, 0, raymarch_sample, NULL, NULL, VSD_CUDA_ENTRY(vsd_cuda_raymarch_view),
};

static vsd_status raymarch_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                                  char *err, size_t errlen)
{
    raymarch_state *s = state;
    ctx->kd.lights = s->lights;
    ctx->kd.light_count = s->opt.lights;
    ctx->kd.march_step = vsd_method_march_step(ctx, s->opt.step);
    ctx->kd.march_stop = (float)s->opt.early_termination;
    return vsd_method_render_stratified(ctx, fb, s->opt.pixel_samples, &raymarch_view_pass, NULL, &ctx->kd, samples,
                                        err, errlen);
}

static void raymarch_destroy(void *state)
{
    raymarch_state *s = state;
    if (!s) return;
    free(s->lights);
    free(s);
}

const vsd_method vsd_method_raymarch = {
    .name = "raymarch",
    .label = "Ray March (slow baseline)",
    .summary = "The papers' brute-force baseline, for comparisons: single scattering only, every march step "
               "sends a shadow ray to each of K environment directions (256 by default), with no acceleration. "
               "Slow: smoke128 at 640x360 takes hours on a few cores; reference, lbl or crm for pictures",
    .caps = VSD_METHOD_CAP_CUDA_VIEW | VSD_METHOD_CAP_SEVERAL_VOLUMES,
    .roles = 0,
    .options = VSD_OPTION_TABLE(raymarch_option_rows, raymarch_options),
    .create = raymarch_create,
    .prepare_frame = NULL,
    .prepare_lighting = raymarch_prepare_lighting,
    .render = raymarch_render,
    .destroy = raymarch_destroy,
};
