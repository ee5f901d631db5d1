/* Method `raymarch`: the brute-force single-scattering baseline (raymarch_kernel.h).
 * Lighting preparation picks the K fixed environment directions; the view pass marches
 * n x n stratified rays per pixel (a box filter like the reference's, without noise).
 * Options: lights (K, default 256), step (world units, default half the smallest voxel),
 * pixel_samples (n, default 2). */
#include "src/render/method.h"
#include "src/render/accum.h"
#include "src/render/env_lights.h"
#include "device/cpu/cpu_tiles.h"
#include "raymarch_kernel.h"
#include <stdlib.h>

static const char *const raymarch_options[] = { "lights", "step", "pixel_samples", NULL };

typedef struct raymarch_state {
    float *lights;
    int count;
    int pixel_samples;
} raymarch_state;

typedef struct raymarch_pass {
    const vsd_kernel_data *kd;
    vsd_accum *acc;
    int n;
} raymarch_pass;

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

static void raymarch_tile(void *user, int x0, int y0, int x1, int y1)
{
    raymarch_pass *p = user;
    int x, y, i, j;
    float inv = 1.0f / (float)p->n;
    for (y = y0; y < y1; y++)
        for (x = x0; x < x1; x++)
            for (j = 0; j < p->n; j++)
                for (i = 0; i < p->n; i++) {
                    vsd_sample_result res = vsd_raymarch_pixel(p->kd, x, y, ((float)i + 0.5f) * inv, ((float)j + 0.5f) * inv);
                    vsd_accum_add(p->acc, x, y, &res);
                }
}

static vsd_status raymarch_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                                  char *err, size_t errlen)
{
    raymarch_state *s = state;
    vsd_accum acc;
    raymarch_pass pass;
    vsd_tile_job job;
    vsd_status st;
    float step = (float)vsd_scene_option_number(ctx->scene, "step", 0.0);
    ctx->kd.lights = s->lights;
    ctx->kd.light_count = s->count;
    ctx->kd.march_step = step > 0 ? step : (ctx->kd.density.step > 0 ? ctx->kd.density.step : ctx->kd.emission.step);
    if (!(ctx->kd.march_step > 0)) ctx->kd.march_step = 0.01f;
    st = vsd_accum_init(&acc, fb->width, fb->height, err, errlen);
    if (st) return st;
    pass.kd = &ctx->kd;
    pass.acc = &acc;
    pass.n = s->pixel_samples;
    vsd_method_tile_job(&job, ctx, fb, raymarch_tile, &pass, "ray marching");
    st = vsd_cpu_run_tiles(&job);
    if (st == VSD_ERR_CANCELLED) vsd_fail(st, err, errlen, "render cancelled");
    vsd_accum_resolve(&acc, pass.n * pass.n, ctx->scene->film.transparent, fb);
    vsd_accum_free(&acc);
    *samples = pass.n * pass.n;
    return st;
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
