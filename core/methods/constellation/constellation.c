/* Method `constellation` (Navarro, Gutierrez & Serón 2009): the accelerated sibling of
 * `raymarch`. Stages, as the paper does them:
 *   prepare_frame     distance maps of the density (and emission) grid — per volume frame;
 *   prepare_lighting  the light constellation (median cut or k-means), built once per map
 *                     content and light count, then only rotated/scaled for a new
 *                     rotation or strength;
 *   render            validity-mask pass (iFirst per view ray), then the lighting pass on
 *                     spherical shells with shadow rays to every light.
 * The kernels are in constellation_kernel.h; options are documented in
 * docs/methods/constellation.md. */
#include "src/render/method.h"
#include "src/render/accum.h"
#include "src/render/distance_map.h"
#include "src/render/distance_map_device.h"
#include "device/cpu/cpu_tiles.h"
#include "vsd/lighting.h"
#include "constellation_kernel.h"
#include "dense_grid.h"
#include "constellation_device.h"
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct cst_options {
    int lights;
    int lights_method;         /* vsd_lights_method: the index into lights_method_names */
    double slice;              /* 0 = half a voxel */
    double threshold;
    double shadow_step;        /* 0 = half a voxel */
    double early_termination;
    int distance_map, validity_mask, pixel_samples;
} cst_options;

/* in vsd_lights_method's order */
static const char *const lights_method_names[] = {"median_cut", "kmeans", NULL};

static const vsd_option_spec cst_option_rows[] = {
    {"lights", VSD_OPT_INT, 1, 65536, 64, NULL, "N: the map as N lights (the constellation)",
     offsetof(cst_options, lights), 0, NULL},
    {"lights_method", VSD_OPT_CHOICE, 0, 0, VSD_LIGHTS_MEDIAN_CUT, lights_method_names,
     "equal-energy median cut, or k-means refined from it", offsetof(cst_options, lights_method), 0, NULL},
    {"slice", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "spacing of the view-sample shells, world units (0 = half a voxel)",
     offsetof(cst_options, slice), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL},
    {"density_threshold", VSD_OPT_NUMBER, 0, 1e30, 0, NULL,
     "grid values at or below this count as empty for the distance map and the mask",
     offsetof(cst_options, threshold), 0, NULL},
    {"shadow_step", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "shadow-ray step, world units (0 = half a voxel)",
     offsetof(cst_options, shadow_step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL},
    {"early_termination", VSD_OPT_NUMBER, 0, 1, 1e-3, NULL, "stop a view ray once its transmittance is below this",
     offsetof(cst_options, early_termination), 0, NULL},
    {"distance_map", VSD_OPT_BOOL, 0, 1, 1, NULL, "leap over empty space with the Euclidean distance map (§4.1)",
     offsetof(cst_options, distance_map), 0, NULL},
    {"validity_mask", VSD_OPT_BOOL, 0, 1, 1, NULL, "start each view ray at its first non-empty shell (§4.2)",
     offsetof(cst_options, validity_mask), 0, NULL},
    {"pixel_samples", VSD_OPT_INT, 1, 16, 1, NULL, "n: n x n stratified view rays per pixel",
     offsetof(cst_options, pixel_samples), 0, NULL},
};

typedef struct cst_state {
    cst_options opt;
    vsd_distance_map dm_density, dm_emission;
    vsd_dense_grid field;       /* dense copy of the density grid for the shadow rays */
    vsd_light_constellation cons;
    uint64_t cons_key;          /* hash of the map content the constellation came from */
    int cons_valid;
    float *lights;              /* kernel layout, rotated and scaled */
    int light_count;
} cst_state;

static vsd_status cst_create(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen)
{
    cst_state *s = calloc(1, sizeof *s);
    (void)scene;
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *(const cst_options *)options;
    *state = s;
    return VSD_OK;
}

/* Per volume frame: the distance maps (the paper's only per-frame preprocessing) and the
 * dense copy of the density grid the shadow rays sample (the paper's 3D texture upload;
 * made in every mode, so the accelerations are compared on the same lookup). The emission
 * map is built whenever an emission grid is loaded, because emission strength changes
 * re-run only prepare_lighting. */
/* The paper builds the map per frame on the GPU; so does vsd when the frame runs there
 * (the same map either way: tests/test_cuda.c). */
static vsd_status build_map(const vsd_frame_ctx *ctx, int emission, float threshold, vsd_distance_map *dm, char *err,
                            size_t errlen)
{
    const vsd_volume *vol = emission ? ctx->emission : ctx->density;
    if (ctx->cuda) return vsd_distance_map_build_device(ctx, vol, emission, threshold, dm, err, errlen);
    return vsd_distance_map_build(vol, threshold, ctx->threads, dm, err, errlen);
}

static vsd_status cst_prepare_frame(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    cst_state *s = state;
    vsd_status st;
    vsd_distance_map_free(&s->dm_density);
    vsd_distance_map_free(&s->dm_emission);
    vsd_dense_grid_free(&s->field);
    if (s->opt.distance_map) {
        st = build_map(ctx, 0, (float)s->opt.threshold, &s->dm_density, err, errlen);
        if (!st && ctx->emission) st = build_map(ctx, 1, (float)s->opt.threshold, &s->dm_emission, err, errlen);
        if (st) return st;
    }
    return vsd_dense_grid_build(ctx->density, s->opt.distance_map ? &s->dm_density : NULL,
                                s->opt.distance_map ? (float)s->opt.threshold : 0.0f, &s->field, err, errlen);
}

/* 64-bit FNV-1a-style mix over the map's size and texel bits: the constellation is reused
 * only for identical content (an address alone could be reused by a new map). */
static uint64_t env_hash(const vsd_env *env)
{
    uint64_t h = 1469598103934665603ull ^ ((uint64_t)env->width << 32 | (uint32_t)env->height);
    const uint32_t *p = (const uint32_t *)(const void *)env->rgb;
    size_t i, n = (size_t)env->width * env->height * 3;
    for (i = 0; i < n; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

/* Per lighting change: rebuild the constellation only when the map itself changed; a new
 * rotation or strength just re-derives the kernel lights (no recomputation, §3). */
static vsd_status cst_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    cst_state *s = state;
    const vsd_scene *sc = ctx->scene;
    uint64_t key = env_hash(ctx->env);
    if (!s->cons_valid || key != s->cons_key) {
        vsd_status st;
        vsd_constellation_free(&s->cons);
        s->cons_valid = 0;
        st = vsd_constellation_build(ctx->env, s->opt.lights, (vsd_lights_method)s->opt.lights_method, &s->cons, err, errlen);
        if (st) return st;
        s->cons_key = key;
        s->cons_valid = 1;
    }
    free(s->lights);
    s->lights = malloc(sizeof(float) * 8 * (size_t)(s->cons.count > 0 ? s->cons.count : 1));
    if (!s->lights) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d lights", s->cons.count);
    vsd_constellation_kernel_lights(&s->cons, sc->environment.strength, sc->environment.rotation_z, s->lights);
    s->light_count = s->cons.count;
    return VSD_OK;
}

typedef struct cst_pass {
    const vsd_kconstellation *kc;
    vsd_accum *acc;
    int32_t *first;
} cst_pass;

static void mask_tile(void *user, int x0, int y0, int x1, int y1)
{
    cst_pass *p = user;
    int x, y, s, n2 = p->kc->pixel_samples * p->kc->pixel_samples, w = p->kc->kd->camera.width;
    for (y = y0; y < y1; y++)
        for (x = x0; x < x1; x++)
            for (s = 0; s < n2; s++) p->first[((size_t)y * w + x) * n2 + s] = vsd_cst_first_shell(p->kc, x, y, s);
}

static void light_tile(void *user, int x0, int y0, int x1, int y1)
{
    cst_pass *p = user;
    int x, y, s, n2 = p->kc->pixel_samples * p->kc->pixel_samples;
    for (y = y0; y < y1; y++)
        for (x = x0; x < x1; x++)
            for (s = 0; s < n2; s++) {
                vsd_sample_result r = vsd_cst_sample(p->kc, x, y, s);
                vsd_accum_add(p->acc, x, y, &r);
            }
}

/* The kernel view of a distance map and/or a dense grid over the same cells; either may
 * be absent (NULL arrays). Both come from the same volume, so when both exist their origin
 * and dims agree by construction (vol->origin, 8 * brick_dims). */
static void kdistmap_from(vsd_kdistmap *k, const vsd_distance_map *dm, const vsd_dense_grid *g)
{
    memset(k, 0, sizeof *k);
    if (dm && dm->skip) {
        k->skip = dm->skip;
        memcpy(k->origin, dm->origin, sizeof k->origin);
        memcpy(k->dims, dm->dims, sizeof k->dims);
    }
    if (g && g->v && (!k->skip || (memcmp(g->origin, k->origin, sizeof k->origin) == 0 &&
                                   memcmp(g->dims, k->dims, sizeof k->dims) == 0))) {
        k->field = g->v;
        k->shadow_code = g->code;
        memcpy(k->origin, g->origin, sizeof k->origin);
        memcpy(k->dims, g->dims, sizeof k->dims);
    }
}

/* The default step: half the smallest voxel of the density grid (or of the emission grid
 * when there is no density). */
static float half_voxel(const vsd_frame_ctx *ctx)
{
    float h = ctx->kd.density.step > 0 ? ctx->kd.density.step : ctx->kd.emission.step;
    return h > 0 ? h : 0.01f;
}

static vsd_status cst_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples, char *err,
                             size_t errlen)
{
    cst_state *s = state;
    vsd_kconstellation kc;
    vsd_accum acc;
    cst_pass pass;
    vsd_tile_job job;
    vsd_status st;
    int n2 = s->opt.pixel_samples * s->opt.pixel_samples;
    ctx->kd.lights = s->lights;
    ctx->kd.light_count = s->light_count;
    memset(&kc, 0, sizeof kc);
    kc.kd = &ctx->kd;
    kc.slice = s->opt.slice > 0 ? (float)s->opt.slice : half_voxel(ctx);
    kc.shadow_step = s->opt.shadow_step > 0 ? (float)s->opt.shadow_step : half_voxel(ctx);
    ctx->kd.march_step = kc.shadow_step;
    kc.threshold = (float)s->opt.threshold;
    kc.early_termination = (float)s->opt.early_termination;
    kc.pixel_samples = s->opt.pixel_samples;
    kc.use_distance_map = s->opt.distance_map;
    kdistmap_from(&kc.dm_density, s->opt.distance_map ? &s->dm_density : NULL, &s->field);
    if (s->opt.distance_map) kdistmap_from(&kc.dm_emission, &s->dm_emission, NULL);
    if (ctx->cuda) {
        if ((st = vsd_accum_init(&acc, fb->width, fb->height, err, errlen))) return st;
        st = vsd_cst_device_render(ctx, &kc, s->opt.validity_mask, &acc, err, errlen);
        if (!st || st == VSD_ERR_CANCELLED) vsd_accum_resolve(&acc, n2, ctx->scene->film.transparent, fb);
        vsd_accum_free(&acc);
        *samples = n2;
        return st;
    }
    memset(&pass, 0, sizeof pass);
    pass.kc = &kc;
    if (s->opt.validity_mask) {
        pass.first = malloc(sizeof(int32_t) * (size_t)fb->width * fb->height * n2);
        if (!pass.first)
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%d validity mask", fb->width, fb->height);
        vsd_method_tile_job(&job, ctx, fb, mask_tile, &pass, "validity mask");
        job.progress_span = 0.05f;
        st = vsd_cpu_run_tiles(&job);
        if (st) {
            free(pass.first);
            return vsd_fail(st, err, errlen, "render cancelled");
        }
        kc.first = pass.first;
    }
    st = vsd_accum_init(&acc, fb->width, fb->height, err, errlen);
    if (st) {
        free(pass.first);
        return st;
    }
    pass.acc = &acc;
    vsd_method_tile_job(&job, ctx, fb, light_tile, &pass, "lighting");
    if (s->opt.validity_mask) {
        job.progress_base = 0.05f;
        job.progress_span = 0.95f;
    }
    st = vsd_cpu_run_tiles(&job);
    if (st == VSD_ERR_CANCELLED) vsd_fail(st, err, errlen, "render cancelled");
    vsd_accum_resolve(&acc, n2, ctx->scene->film.transparent, fb);
    vsd_accum_free(&acc);
    free(pass.first);
    *samples = n2;
    return st;
}

static void cst_destroy(void *state)
{
    cst_state *s = state;
    if (!s) return;
    vsd_distance_map_free(&s->dm_density);
    vsd_distance_map_free(&s->dm_emission);
    vsd_dense_grid_free(&s->field);
    vsd_constellation_free(&s->cons);
    free(s->lights);
    free(s);
}

const vsd_method vsd_method_constellation = {
    "constellation", VSD_OPTION_TABLE(cst_option_rows, cst_options), cst_create, cst_prepare_frame, cst_prepare_lighting, cst_render,
    cst_destroy,
};
