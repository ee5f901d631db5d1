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
#include "src/method/method.h"
#include "src/render/accum.h"
#include "src/grids/distance_map.h"
#include "src/device_data/distance_map_device.h"
#include "device/cpu/cpu_tiles.h"
#include "vsd/lighting.h"
#include "constellation_kernel.h"
#include "dense_grid.h"
#include "constellation_device.h"
#include "src/grids/record_grid.h"
#include "src/grids/kvolume_boxes.h"
#include "kernel/kernel_record_grid.h"
#include "src/grids/volume_groups.h"
#include "src/method/method_parts.h"
#include "src/method/density_levels.h"
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
    int shadows;               /* SHADOWS_GRID or SHADOWS_RAYS */
    int shadow_grid;           /* record cells per axis (shadows = grid) */
    int interp;                /* VSD_RECORDS_NEAREST.. (shadows = grid) */
    int shadow_density;        /* VSD_DENSITY_AUTO / FULL (shadows = grid) */
    vsd_view_sampling view;    /* the adaptive view (shadows = grid) */
    int view_bake;             /* the lights' term per record once per view (shadows = grid) */
} cst_options;

enum { SHADOWS_GRID = 0, SHADOWS_RAYS = 1 };

/* in vsd_lights_method's order */
static const char *const lights_method_names[] = {"median_cut", "kmeans", NULL};
static const char *const shadows_names[] = {"grid", "rays", NULL};
/* in VSD_RECORDS_NEAREST.. order */
static const char *const interp_names[] = {"nearest", "trilinear", "log", NULL};

/* The shadow grid's own settings mean nothing with the paper's shadow rays. */
static const vsd_option_when cst_on_shadow_grid[] = {{"shadows", 0, 0, "grid"}, {NULL, 0, 0, NULL}};
/* The validity mask starts the paper's per-sample shadow-ray march; the grid's view pass
 * has its own empty-space skipping (cst_render). */
static const vsd_option_when cst_on_shadow_rays[] = {{"shadows", 0, 0, "rays"}, {NULL, 0, 0, NULL}};
/* the adaptive view's threshold: on the record grid's view, which samples sparsely */
static const vsd_option_when cst_on_sparse_grid_view[] = {
    {"shadows", 0, 0, "grid"}, {"view_spacing", 1, 1, NULL}, {NULL, 0, 0, NULL}};

static const vsd_option_spec cst_option_rows[] = {
    {"lights", VSD_OPT_INT, 1, 65536, 64, NULL, "N: the map as N lights (the constellation)",
     offsetof(cst_options, lights), 0, NULL, NULL},
    {"lights_method", VSD_OPT_CHOICE, 0, 0, VSD_LIGHTS_MEDIAN_CUT, lights_method_names,
     "equal-energy median cut, or k-means refined from it", offsetof(cst_options, lights_method), 0, NULL, NULL},
    {"slice", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "view step (shell spacing), world units (0 = half a voxel for rays, a voxel for the grid)",
     offsetof(cst_options, slice), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    {"density_threshold", VSD_OPT_NUMBER, 0, 1e30, 0, NULL,
     "grid values at or below this count as empty for the distance map and the mask",
     offsetof(cst_options, threshold), 0, NULL, NULL},
    {"shadow_step", VSD_OPT_NUMBER, 0, 1e30, 0, NULL,
     "shadow-ray step, world units (0 = half a voxel for rays, a voxel for the grid's records)",
     offsetof(cst_options, shadow_step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    VSD_OPTION_EARLY_TERMINATION(cst_options, "view or shadow ray"),
    {"distance_map", VSD_OPT_BOOL, 0, 1, 1, NULL, "leap over empty space with the Euclidean distance map (§4.1)",
     offsetof(cst_options, distance_map), 0, NULL, NULL},
    {"validity_mask", VSD_OPT_BOOL, 0, 1, 1, NULL, "start each view ray at its first non-empty shell (§4.2)",
     offsetof(cst_options, validity_mask), 0, NULL, .when = cst_on_shadow_rays},
    VSD_OPTION_PIXEL_SAMPLES(cst_options),
    /* the record grid's view is as smooth between pixels as lbl's and crm's (the same
       deterministic march over trilinear fields); the rays' view keeps its validity mask */
    VSD_OPTION_VIEW_SPACING_WHEN(cst_options, view.spacing, view.threshold, cst_on_shadow_grid, cst_on_sparse_grid_view),
    {"view_bake", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "grid, CPU view: the lights' term per record once per view, phase at the camera-to-record direction, as lbl's "
     "(false = the lights summed per record a ray crosses, phase at the ray's direction)",
     offsetof(cst_options, view_bake), 0, NULL, .when = cst_on_shadow_grid},
    {"shadows", VSD_OPT_CHOICE, 0, 0, SHADOWS_GRID, shadows_names,
     "grid: each light's transmittance cached on a record grid per lighting change; rays: the paper's shadow rays "
     "per view sample", offsetof(cst_options, shadows), 0, NULL, NULL},
    {"shadow_grid", VSD_OPT_INT, 0, 256, 0, NULL,
     "shadows = grid: record cells per axis over the density's box (0 = cubic cells following the box's shape, "
     "at most 2 voxels and a 64th of its shortest axis, 64..128 along its longest)",
     offsetof(cst_options, shadow_grid), 0, NULL, .when = cst_on_shadow_grid},
    {"interpolation", VSD_OPT_CHOICE, 0, 0, VSD_RECORDS_LOG_TRILINEAR, interp_names,
     "shadows = grid: record lookup, nearest cell, trilinear, or trilinear in log radiance",
     offsetof(cst_options, interp), 0, NULL, .when = cst_on_shadow_grid},
    {"shadow_density", VSD_OPT_CHOICE, 0, 0, VSD_DENSITY_AUTO, vsd_density_choice_names,
     "shadows = grid: density the shadow rays read: auto (the coarsest 2x-reduced level whose voxel fits in a "
     "cell and that keeps the data's detail) or full (the source voxels)",
     offsetof(cst_options, shadow_density), 0, NULL, .when = cst_on_shadow_grid},
};

typedef struct cst_state {
    cst_options opt;
    vsd_distance_map dm_density, dm_emission;
    vsd_dense_grid field;       /* dense copy of the density grid for the shadow rays */
    vsd_constellation_cache cc;   /* the constellation and its kernel lights, rotated and scaled */
    /* shadows = grid: records over the density's box, each light's transmittance from
     * each record (per lighting change), or for an isotropic phase the baked RGB */
    vsd_record_grid rg;
    /* the density the shadow grid's rays read, per volume; with a level above 0 the
     * distance map and the dense field above are built from it */
    vsd_density_levels levels;
    float *light_trans;         /* [rg.count * light_count] */
    float *baked;               /* [rg.count * 3], NULL when g != 0 */
    /* several volumes (shadows "grid"): a part per volume, its cached shadows marched
     * through its own volume by the paper's rays and through the others plainly
     * (src/method/method_parts.h) */
    vsd_method_parts parts;
} cst_state;

static vsd_status cst_create(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen)
{
    const cst_options *o = options;
    cst_state *s;
    (void)scene;
    if (o->shadows == SHADOWS_GRID && o->lights > VSD_RECORDS_MAX_LIGHTS)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "render.options.lights: %d is more than the %d lights a record holds with shadows = \"grid\" "
                        "(use shadows = \"rays\" for more)", o->lights, (int)VSD_RECORDS_MAX_LIGHTS);
    s = calloc(1, sizeof *s);
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *o;
    *state = s;
    return VSD_OK;
}

/* Per volume frame: the distance maps (the paper's only per-frame preprocessing) and the
 * dense copy of the density grid the shadow rays sample (the paper's 3D texture upload;
 * made in every mode, so the accelerations are compared on the same lookup). The emission
 * map serves only the per-sample view leaps (shadows = rays); there it is built whenever an
 * emission grid is loaded, because emission strength changes re-run only
 * prepare_lighting. With shadows = grid, the record grid too. */
/* The paper builds the map per frame on the GPU; so does vsd when the frame runs there
 * (the same map either way: tests/test_cuda.c). */
/* The distance map of vol: on the device when it is one of the frame's own grids there
 * (a density level lives on the host only). */
static vsd_status build_map(const vsd_frame_ctx *ctx, const vsd_volume *vol, int emission, float threshold,
                            vsd_distance_map *dm, char *err, size_t errlen)
{
    if (ctx->cuda && vol == (emission ? ctx->emission : ctx->density))
        return vsd_distance_map_build_device(ctx, vol, emission, threshold, dm, err, errlen);
    return vsd_distance_map_build(vol, threshold, ctx->threads, dm, err, errlen);
}

static void free_shadow_records(cst_state *s)
{
    vsd_record_grid_free(&s->rg);
    vsd_density_levels_free(&s->levels);
    free(s->light_trans);
    free(s->baked);
    s->light_trans = s->baked = NULL;
}

static vsd_status light_shadow_records(cst_state *s, vsd_frame_ctx *ctx, char *err, size_t errlen);

/* shadow_grid = 0: cubic cells (index space) no larger than a 64^3 grid's along the box's
 * shortest axis nor than 2 voxels, 64 to 128 of them along its longest axis. The fixed
 * 64^3 spread 3.5 voxels over a cell along the long axis of a 111x223x112-voxel Houdini
 * smoke and 1.75 across it: VolumeDir 2.80% against the shadow rays' 2.17%; the same count
 * of cubic cells at 2 voxels coarsened a flat cloud's short axes (cloud128 4.4 -> 5.1%)
 * (docs/methods/constellation.md, "The shadow grid follows the volume"). */
static int auto_shadow_cells(const vsd_kvolume *v)
{
    int longest, shortest, cells;
    vsd_kvolume_brick_extent(v, &longest, &shortest);
    if (shortest <= 0) return 64;
    cells = (longest + 1) / 2;                                       /* 2 voxels */
    if (64 * longest / shortest > cells) cells = 64 * longest / shortest;   /* 64 across */
    return cells < 64 ? 64 : cells > 128 ? 128 : cells;
}

/* A part's frame stage (below) builds its distance map, field and shadow grid from its own
 * volume alone; the others reach it in the lighting stage. */
static uint32_t cst_part_reads(const vsd_frame_ctx *ctx) { return 1u << ctx->part.volume; }

static vsd_status cst_prepare_frame(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    cst_state *s = state;
    const vsd_volume *shadow_vol = ctx->density;   /* what the map and the dense field copy */
    vsd_status st;
    if (!ctx->part.active && ctx->kd.volume_count > 1) {
        if (s->opt.shadows != SHADOWS_GRID)
            return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                            "constellation: render.options.shadows \"rays\" renders one volume; with %d volumes use "
                            "\"grid\" (the default)",
                            ctx->kd.volume_count);
        return vsd_parts_prepare_frame(&s->parts, &vsd_method_constellation, &s->opt, cst_part_reads, ctx, err,
                                       errlen);
    }
    if (!ctx->part.active) vsd_parts_free(&s->parts, &vsd_method_constellation);
    vsd_distance_map_free(&s->dm_density);
    vsd_distance_map_free(&s->dm_emission);
    vsd_dense_grid_free(&s->field);
    free_shadow_records(s);
    /* probes 2: 8 density probes per cell besides the brick majorants */
    if (s->opt.shadows == SHADOWS_GRID) {
        const int self = ctx->part.active ? ctx->part.volume : 0;
        if ((st = s->opt.shadow_grid > 0
                      ? vsd_record_grid_build(&ctx->kd.density, s->opt.shadow_grid, 2, &s->rg, err, errlen)
                      : vsd_record_grid_build_shaped(&ctx->kd.density, auto_shadow_cells(&ctx->kd.density), 2, &s->rg,
                                                     err, errlen)) ||
            (st = vsd_density_levels_for_grid(&s->levels, ctx, &s->rg, s->opt.shadow_density, err, errlen)))
            return st;
        /* the shadow rays read the density at the cells' resolution; in this mode the map
           and the dense field serve only them (the view is the record grid's march) */
        if (s->levels.level[self] > 0) shadow_vol = s->levels.mip[self][s->levels.level[self] - 1];
    }
    if (s->opt.distance_map) {
        st = build_map(ctx, shadow_vol, 0, (float)s->opt.threshold, &s->dm_density, err, errlen);
        /* the emission map serves only the per-sample view leaps of shadows = rays */
        if (!st && ctx->emission && s->opt.shadows == SHADOWS_RAYS)
            st = build_map(ctx, ctx->emission, 1, (float)s->opt.threshold, &s->dm_emission, err, errlen);
        if (st) return st;
    }
    return vsd_dense_grid_build(shadow_vol, s->opt.distance_map ? &s->dm_density : NULL,
                                s->opt.distance_map ? (float)s->opt.threshold : 0.0f, &s->field, err, errlen);
}

/* Per lighting change: rebuild the constellation only when the map itself changed; a new
 * rotation or strength just re-derives the kernel lights (no recomputation, §3). */
static vsd_status cst_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    cst_state *s = state;
    const vsd_scene *sc = ctx->scene;
    vsd_status st;
    if (s->parts.count) return vsd_parts_prepare_lighting(&s->parts, &vsd_method_constellation, ctx, err, errlen);
    st = vsd_constellation_cache_update(&s->cc, ctx->env, s->opt.lights,
                                                   (vsd_lights_method)s->opt.lights_method, sc->environment.strength,
                                                   sc->environment.rotation_z, err, errlen);
    if (st) return st;
    if (s->opt.shadows == SHADOWS_GRID) return light_shadow_records(s, ctx, err, errlen);
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

/* The method's kernel data for this frame (ctx->kd gets the lights and the march step). */
static void kernel_setup(cst_state *s, vsd_frame_ctx *ctx, vsd_kconstellation *kc)
{
    ctx->kd.lights = s->cc.lights;
    ctx->kd.light_count = s->cc.count;
    memset(kc, 0, sizeof *kc);
    kc->kd = &ctx->kd;
    kc->slice = vsd_method_march_step(ctx, s->opt.slice);
    /* the cached shadows are interpolated between records anyway: by default their rays
     * step a whole voxel (VolumeDir moved 0.06% on smoke128 frame 45, the stage took half
     * the time); the per-sample rays keep the paper's half voxel */
    kc->shadow_step = s->opt.shadow_step > 0 || s->opt.shadows == SHADOWS_RAYS
                          ? vsd_method_march_step(ctx, s->opt.shadow_step)
                          : 2.0f * vsd_method_march_step(ctx, 0.0);
    ctx->kd.march_step = kc->shadow_step;
    kc->threshold = (float)s->opt.threshold;
    kc->early_termination = (float)s->opt.early_termination;
    kc->pixel_samples = s->opt.pixel_samples;
    kc->use_distance_map = s->opt.distance_map;
    kdistmap_from(&kc->dm_density, s->opt.distance_map ? &s->dm_density : NULL, &s->field);
    if (s->opt.distance_map) kdistmap_from(&kc->dm_emission, &s->dm_emission, NULL);
}

/* shadows = grid: the record grid as the shared view pass reads it */
static void records_view(const cst_state *s, const vsd_kernel_data *kd, vsd_krecord_grid *g)
{
    memset(g, 0, sizeof *g);
    g->kd = kd;
    g->cell_record = s->rg.cell_record;
    g->world_to_grid = s->rg.world_to_grid;
    memcpy(g->res, s->rg.res, sizeof g->res);
    g->record_count = s->rg.count;
    g->interp = s->opt.interp;
    if (s->baked) {
        g->kind = VSD_RECORDS_BAKED;
        g->records = s->baked;
        g->stride = 3;
    } else {
        g->kind = VSD_RECORDS_LIGHTS;
        g->lights = s->cc.lights;
        g->light_trans = s->light_trans;
        g->light_count = s->cc.count;
    }
}

typedef struct shadow_job {
    const vsd_kconstellation *kc;
    const vsd_record_grid *rg;
    float *out;
} shadow_job;

static void shadow_tile(void *user, int x0, int y0, int x1, int y1)
{
    shadow_job *j = user;
    int r, n = j->kc->kd->light_count;
    (void)y0; (void)y1;
    for (r = x0; r < x1; r++) {
        const float *p = j->rg->record_pos + 4 * (size_t)r;
        vsd_cst_light_record(j->kc, f3(p[0], p[1], p[2]), j->out + (size_t)r * n);
    }
}

/* shadows = grid, per lighting change: every record's transmittance toward every light
 * (the paper's shadow rays, once per record instead of once per view sample); with an
 * isotropic phase the in-scattered RGB sum_n T_n L_n / 4pi is then baked per record, so
 * the view pass reads one RGB triple per corner. On the CUDA backend this stage runs on the
 * CPU threads (a device launcher for it is future work); the view pass runs on the GPU. */
static vsd_status light_shadow_records(cst_state *s, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    vsd_kconstellation kc;
    vsd_kernel_data coarse;
    vsd_kobject coarse_objects[VSD_KMAX_VOLUMES];
    shadow_job job;
    vsd_tile_job tj;
    vsd_status st;
    free(s->light_trans);
    free(s->baked);
    s->light_trans = s->baked = NULL;
    if (s->rg.count == 0 || s->cc.count == 0) return VSD_OK;
    s->light_trans = malloc(sizeof(float) * (size_t)s->rg.count * (size_t)s->cc.count);
    if (!s->light_trans)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d x %d cached shadows", s->rg.count, s->cc.count);
    kernel_setup(s, ctx, &kc);
    /* the rays read the density at the cells' resolution: a voxel apart, or a cell where
       they read a coarser level (density_levels.h) */
    vsd_density_levels_kd(&s->levels, &ctx->kd, &coarse, coarse_objects);
    if (s->opt.shadow_step <= 0)
        coarse.march_step = kc.shadow_step = s->levels.step > 0 ? s->levels.step : 2.0f * vsd_kd_march_step(&coarse, 0.0);
    kc.kd = &coarse;
    job.kc = &kc;
    job.rg = &s->rg;
    job.out = s->light_trans;
    vsd_method_item_job(&tj, ctx, s->rg.count, shadow_tile, &job, "cached shadows");
    if ((st = vsd_cpu_run_tiles(&tj))) return vsd_fail(st, err, errlen, "cached shadows cancelled");
    /* a part: the other volumes' shadows on the same rays */
    if (ctx->part.active)
        vsd_group_shadow_records(&coarse, 1u << ctx->part.volume, s->rg.record_pos, s->rg.count, s->cc.lights,
                                 s->cc.count, NULL, 0, s->light_trans, NULL, NULL, ctx->threads);
    if (ctx->kd.medium.anisotropy == 0.0f) {
        vsd_krecord_grid g;
        records_view(s, &ctx->kd, &g);   /* the LIGHTS kind, while s->baked is NULL */
        if ((st = vsd_record_grid_bake(&g, &s->baked, err, errlen))) return st;
        /* baked records hold the lights' term: the transmittances are not read again */
        free(s->light_trans);
        s->light_trans = NULL;
    }
    return VSD_OK;
}

/* shadows = grid, per view: the shared march with the record lookup, slice as its step */
static vsd_status render_cached(cst_state *s, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples, char *err,
                                size_t errlen)
{
    vsd_krecord_grid g;
    ctx->kd.lights = s->cc.lights;
    ctx->kd.light_count = s->cc.count;
    records_view(s, &ctx->kd, &g);
    if (g.kind == VSD_RECORDS_LIGHTS && s->opt.view_bake && !ctx->cuda)
        /* (an isotropic phase was baked once, per lighting: records_view's BAKED kind) */
        return vsd_record_grid_render_baked(ctx, fb, &g, s->rg.record_pos, s->opt.pixel_samples, s->opt.slice,
                                            s->opt.early_termination, &s->opt.view, samples, err, errlen);
    return vsd_record_grid_render(ctx, fb, &g, s->opt.pixel_samples, s->opt.slice, s->opt.early_termination, &s->opt.view,
                                  samples, err, errlen);
}

/* a part's record grid (src/method/method_parts.h) */
static vsd_status view_part(void *state, vsd_frame_ctx *ctx, vsd_krecord_grid *g, char *err, size_t errlen)
{
    (void)err;
    (void)errlen;
    records_view(state, &ctx->kd, g);
    return VSD_OK;
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
    if (s->parts.count)
        return vsd_parts_render(&s->parts, view_part, ctx, fb, s->opt.pixel_samples, s->opt.slice,
                                s->opt.early_termination, &s->opt.view, samples, err, errlen);
    if (s->opt.shadows == SHADOWS_GRID) {
        if (ctx->info && ctx->info_len)
            snprintf(ctx->info, ctx->info_len,
                     "shadow_cells=%dx%dx%d records=%d lights=%d density_level=%d density_level_seconds=%.3f",
                     s->rg.res[0], s->rg.res[1], s->rg.res[2], s->rg.count, s->cc.count, s->levels.level[0],
                     s->levels.seconds);
        return render_cached(s, ctx, fb, samples, err, errlen);
    }
    kernel_setup(s, ctx, &kc);
    if (ctx->cuda) {
        st = vsd_accum_init(&acc, ctx->accum_store, ctx->threads, fb->width, fb->height, err, errlen);
        if (st) return st;
        st = vsd_cst_device_render(ctx, &kc, s->opt.validity_mask, &acc, err, errlen);
        if (!st || st == VSD_ERR_CANCELLED)
            vsd_accum_resolve(&acc, n2, ctx->scene->film.transparent, ctx->threads, fb);
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
    st = vsd_accum_init(&acc, ctx->accum_store, ctx->threads, fb->width, fb->height, err, errlen);
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
    vsd_accum_resolve(&acc, n2, ctx->scene->film.transparent, ctx->threads, fb);
    vsd_accum_free(&acc);
    free(pass.first);
    *samples = n2;
    return st;
}

static void cst_destroy(void *state)
{
    cst_state *s = state;
    if (!s) return;
    vsd_parts_free(&s->parts, &vsd_method_constellation);
    vsd_distance_map_free(&s->dm_density);
    vsd_distance_map_free(&s->dm_emission);
    vsd_dense_grid_free(&s->field);
    free_shadow_records(s);
    vsd_constellation_cache_free(&s->cc);
    free(s);
}

const vsd_method vsd_method_constellation = {
    .name = "constellation",
    .label = "Constellation",
    .summary = "Navarro 2009: light constellation, distance map",
    .caps = VSD_METHOD_CAP_CUDA_VIEW | VSD_METHOD_CAP_SEVERAL_VOLUMES,
    .roles = 0,
    .options = VSD_OPTION_TABLE(cst_option_rows, cst_options),
    .create = cst_create,
    .prepare_frame = cst_prepare_frame,
    .prepare_lighting = cst_prepare_lighting,
    .render = cst_render,
    .destroy = cst_destroy,
};
