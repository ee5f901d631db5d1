/* Method `reference`: progressive unbiased volumetric path tracing (reference_kernel.h).
 * Samples are taken in rounds (1, 1, 2, 4, ... up to render.samples) over all tiles, so
 * progress and intermediate images reflect the whole frame. */
#include "src/method/method.h"
#include "src/render/accum.h"
#include "src/device_data/device_frame.h"
#include "device/cpu/cpu_tiles.h"
#include "src/grids/refraction.h"
#include "src/lighting/radiance_cache.h"
#include "reference_kernel.h"
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

typedef struct reference_options {
    int max_bounces, cache;
    double survival;
} reference_options;

/* The methods that can give their light as a cache (method.h's radiance_cache hook): any
 * other value, a single-scattering method's name too, is refused by the option checker,
 * naming the value and these. */
static const char *const reference_cache_names[] = {"none", "lbl", "crm", NULL};
static const vsd_option_when reference_on_cache[] = {{"cache", 1, 0, "none"}, {NULL, 0, 0, NULL}};

static const vsd_option_spec reference_option_rows[] = {
    {"max_bounces", VSD_OPT_INT, 1, 1000000, 1024, NULL,
     "path length limit in scattering events (Russian roulette ends most paths long before)",
     offsetof(reference_options, max_bounces), 0, NULL, NULL},
    {"cache", VSD_OPT_CHOICE, 0, 0, 0, reference_cache_names,
     "a fast method's multiple scattering (lbl or crm) as a control variate: the paths estimate the difference between the "
     "true light and the method's, so they converge to the same image, with less noise where the method is close "
     "(docs/methods/reference.md: crm's cuts a cloud's variance a fifth, for a little more time per sample)",
     offsetof(reference_options, cache), 0, NULL, NULL},
    {"survival", VSD_OPT_NUMBER, 1e-3, 1, 1, NULL,
     "with a cache: from the second scattering on, a path goes on with probability sqrt(survival x its throughput) "
     "(a path that stops keeps the cache's light for the rest; the estimate stays unbiased)",
     offsetof(reference_options, survival), 0, NULL, .when = reference_on_cache},
};

typedef struct reference_state {
    reference_options opt;
    vsd_refraction_field refraction;   /* medium.ior != 1: the bent rays' n field */
    /* render.options.cache: the serving method, its state (its own default options) and
     * the P1 field it gave after its lighting stage */
    const vsd_method *cache_method;
    void *cache_state;
    vsd_radiance_cache cache;
} reference_state;

static void reference_destroy(void *state);

/* The cache's method with its default options. */
static vsd_status create_cache(reference_state *s, const vsd_scene *scene, char *err, size_t errlen)
{
    const vsd_method *m = vsd_method_find(reference_cache_names[s->opt.cache]);
    void *options = NULL;
    vsd_status st;
    if (!m || !m->radiance_cache)   /* (the table lists only methods that serve) */
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "render.options.cache: method '%s' cannot serve",
                        reference_cache_names[s->opt.cache]);
    if ((st = vsd_method_options_from_json(m, NULL, &options, err, errlen))) return st;
    st = m->create(&s->cache_state, scene, options, err, errlen);
    free(options);
    if (!st) s->cache_method = m;
    return st;
}

static vsd_status reference_create(void **state, const vsd_scene *scene, const void *options, char *err,
                                   size_t errlen)
{
    reference_state *s = calloc(1, sizeof *s);
    vsd_status st;
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *(const reference_options *)options;
    if (s->opt.cache && (st = create_cache(s, scene, err, errlen))) {
        reference_destroy(s);
        return st;
    }
    *state = s;
    return VSD_OK;
}

/* The refractive-index field of the frame when the medium refracts (n = 1 leaves it empty
 * and the path tracer's rays straight: the same code and images as without refraction);
 * the cache's frame stage. */
static vsd_status reference_prepare_frame(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    reference_state *s = state;
    vsd_status st;
    vsd_refraction_free(&s->refraction);
    if ((st = vsd_refraction_for_frame(ctx, &s->refraction, err, errlen))) return st;
    if (!s->cache_method) return VSD_OK;
    if (s->refraction.k.ng)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "render.options.cache: not with a refracting medium yet (medium.ior, volume.ior_grid)");
    return s->cache_method->prepare_frame ? s->cache_method->prepare_frame(s->cache_state, ctx, err, errlen) : VSD_OK;
}

/* The cache's lighting, and its light as the P1 field the paths read. */
static vsd_status reference_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    reference_state *s = state;
    vsd_status st;
    if (!s->cache_method) return VSD_OK;
    vsd_radiance_cache_free(&s->cache);
    if (s->cache_method->prepare_lighting &&
        (st = s->cache_method->prepare_lighting(s->cache_state, ctx, err, errlen)))
        return st;
    if ((st = s->cache_method->radiance_cache(s->cache_state, ctx, &s->cache, err, errlen))) return st;
    s->cache.k.survival = (float)s->opt.survival;
    return VSD_OK;
}

static void reference_destroy(void *state)
{
    reference_state *s = state;
    if (!s) return;
    vsd_refraction_free(&s->refraction);
    vsd_radiance_cache_free(&s->cache);
    if (s->cache_method && s->cache_state) s->cache_method->destroy(s->cache_state);
    free(s);
}

typedef struct reference_round {
    const vsd_kernel_data *kd;
    const vsd_krefract *refract;   /* NULL: straight rays */
    const vsd_kradiance_cache *cache;   /* NULL: none */
    vsd_accum *acc;
    int s0, s1;
} reference_round;

static void reference_tile(void *user, int x0, int y0, int x1, int y1)
{
    reference_round *r = user;
    int x, y, s;
    for (y = y0; y < y1; y++)
        for (x = x0; x < x1; x++)
            for (s = r->s0; s < r->s1; s++) {
                vsd_sample_result res = vsd_reference_sample_bent(r->kd, r->refract, r->cache, x, y, (uint32_t)s);
                vsd_accum_add(r->acc, x, y, &res);
            }
}

static vsd_sample_result reference_pass_sample(const void *kd, int x, int y, int s, int n)
{
    return vsd_reference_pass_sample((const vsd_kernel_data *)kd, x, y, s, n);
}

/* A round of samples [first, first + count) of every pixel on the GPU (reference_cuda.cu). */
VSD_CUDA_ENTRY_DECL(vsd_cuda_reference_round);
static const vsd_device_pass reference_pass = {
    "path tracing", 1, 64, 0, 0, reference_pass_sample, NULL, NULL, VSD_CUDA_ENTRY(vsd_cuda_reference_round),
};

/* The same rounds on the GPU: the device sums each pixel's samples in the CPU's order. */
static vsd_status reference_device(vsd_frame_ctx *ctx, vsd_accum *acc, int total, int *done, char *err,
                                   size_t errlen)
{
    double *dev = NULL;
    int batch = 1;
    vsd_status st = vsd_device_accum(ctx, acc->width, acc->height, &dev, err, errlen);
    while (!st && *done < total) {
        int n = batch < total - *done ? batch : total - *done;
        vsd_pass_args a = {*done, n, 0};
        st = vsd_device_run(ctx, &reference_pass, NULL, &ctx->kd, a, 0, dev,
                            vsd_device_accum_bytes(acc->width, acc->height), (float)*done / (float)total,
                            (float)n / (float)total, err, errlen);
        if (st) break;
        *done += n;
        if (*done >= 2) batch *= 2;
    }
    /* a cancelled render still resolves the rounds it finished */
    return dev ? vsd_device_accum_collect(ctx, dev, acc, st, err, errlen) : st;
}

static vsd_status reference_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                                   char *err, size_t errlen)
{
    const vsd_scene *sc = ctx->scene;
    const reference_state *rs = state;
    vsd_accum acc;
    reference_round round;
    vsd_tile_job job;
    vsd_status st;
    int total = sc->render.samples, done = 0, batch = 1;
    ctx->kd.max_bounces = rs->opt.max_bounces;
    st = vsd_accum_init(&acc, ctx->accum_store, ctx->threads, fb->width, fb->height, err, errlen);
    if (st) return st;
    /* bent rays and the cache have no device pass yet: they render on the CPU threads */
    if (ctx->cuda && !rs->refraction.k.ng && !rs->cache_method) {
        st = reference_device(ctx, &acc, total, &done, err, errlen);
        if (!st || st == VSD_ERR_CANCELLED) {
            if (st) vsd_fail(st, err, errlen, "render cancelled after %d samples", done);
            vsd_accum_resolve(&acc, done, sc->film.transparent, ctx->threads, fb);
        }
        vsd_accum_free(&acc);
        *samples = done;
        return st;
    }
    round.kd = &ctx->kd;
    round.refract = rs->refraction.k.ng ? &rs->refraction.k : NULL;
    round.cache = rs->cache.k.p1 ? &rs->cache.k : NULL;
    round.acc = &acc;
    vsd_method_tile_job(&job, ctx, fb, reference_tile, &round, "path tracing");
    while (done < total) {
        int n = batch < total - done ? batch : total - done;
        round.s0 = done;
        round.s1 = done + n;
        job.progress_base = (float)done / (float)total;
        job.progress_span = (float)n / (float)total;
        st = vsd_cpu_run_tiles(&job);
        if (st) break;
        done += n;
        if (done >= 2) batch *= 2;
    }
    if (st == VSD_ERR_CANCELLED) vsd_fail(st, err, errlen, "render cancelled after %d samples", done);
    vsd_accum_resolve(&acc, done, sc->film.transparent, ctx->threads, fb);
    vsd_accum_free(&acc);
    *samples = done;
    return st;
}

const vsd_method vsd_method_reference = {
    .name = "reference",
    .label = "Reference",
    .summary = "Unbiased volumetric path tracing, all bounces (matches Cycles)",
    .caps = VSD_METHOD_CAP_MULTIPLE_SCATTERING | VSD_METHOD_CAP_REFRACTION | VSD_METHOD_CAP_SCENE_LIGHTS |
            VSD_METHOD_CAP_EMISSION_SCATTERING | VSD_METHOD_CAP_CUDA_VIEW | VSD_METHOD_CAP_SEVERAL_VOLUMES,
    .roles = VSD_METHOD_ROLE_FINAL_DEFAULT,
    .options = VSD_OPTION_TABLE(reference_option_rows, reference_options),
    .create = reference_create,
    .prepare_frame = reference_prepare_frame,
    .prepare_lighting = reference_prepare_lighting,
    .render = reference_render,
    .destroy = reference_destroy,
    .refraction_among_volumes = 1,
};
