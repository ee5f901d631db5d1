/* Method `shgrid`: Delalandre, Gautron, Marvie 2013, "Real-Time Image-Based Volume
 * Lighting" — single scattering from a coarse grid of SH reduced-intensity records
 * (shgrid_kernel.h holds the per-record and per-pixel code shared with CUDA).
 *
 * Stages and caches (the paper's "static lighting", §4.3):
 *   prepare_frame     record grid over the density's box: empty-cell elimination by k^3
 *                     probes, record positions, and in the factored form the SH of the
 *                     transmittance per record (the volume-dependent factor F_Dep).
 *   prepare_lighting  SH of the environment (F_Ind). Factored form: nothing per record
 *                     when g = 0 (environment rotations cost one SH rotation); for g != 0
 *                     the per-record product T*L by the SH triple product. Product form
 *                     (§4.4): T*L projected per record from the HEALPix samples, which
 *                     re-marches the record grid.
 *   render            the view march with one SH dot product per sample.
 * Options: grid (cells per axis, default 0 = automatic: 32..64), order (SH order, default 4), directions
 * (M HEALPix directions, 12 nside^2, default 192), probes (k, k^3 density probes per cell,
 * default 3; 0 = keep every cell whose bricks are not empty), interpolation ("nearest" |
 * "trilinear" | "log", default "log" = trilinear in log radiance), form ("auto" | "factored" | "product", default auto =
 * factored for g = 0, product otherwise), step (view march, world units, default the
 * smallest voxel), record_step (record marches, default one voxel), record_density ("auto":
 * the coarsest density level that fits the cells and keeps the data's detail, or "full";
 * src/method/density_levels.h), pixel_samples (n x n
 * rays per pixel, default 1), lights (K, default 32: extracted bright lights, an extension
 * beyond the paper, see shgrid_kernel.h; 0 = the paper's pure SH form), light_threshold
 * (default 3: texels brighter than this multiple of the map's mean luminance are
 * extracted). The paper's pure form is lights=0, interpolation="nearest". */
#include "src/method/method.h"
#include "src/lighting/env_bright.h"
#include "src/render/accum.h"
#include "src/render/kernel_setup.h"
#include "src/grids/record_grid.h"
#include "src/method/density_levels.h"
#include "src/grids/kvolume_boxes.h"
#include "src/lighting/env_healpix.h"
#include "device/cpu/cpu_tiles.h"
#include "vsd/sh.h"
#include "vsd/lighting.h"
#include "shgrid_kernel.h"
#include "shgrid_device.h"
#include "src/method/method_parts.h"
#include <chealpix.h>
#include <math.h>
#include <stdlib.h>
#include <stddef.h>
#include <string.h>

enum { FORM_AUTO, FORM_FACTORED, FORM_PRODUCT };

/* Defaults chosen for the 5% VolumeDir target (docs/methods/shgrid.md, "Defaults"): order 4
 * (the paper's Table 1 range is 2-4), 32 extracted lights for the texels above 3x the mean
 * luminance, log-trilinear record lookup. */
#define SHGRID_DEFAULT_ORDER 4
#define SHGRID_DEFAULT_LIGHTS 32
#define SHGRID_DEFAULT_LIGHT_THRESHOLD 3.0
/* the record pass's second job: transmittance toward the extracted lights */
enum { PASS_LIGHTS = 2 };

typedef struct shgrid_options {
    int grid, order, directions, probes, interp, form, pixel_samples, lights, record_density, view_bake;
    double step, record_step, light_threshold, early_termination;
    vsd_view_sampling view;
} shgrid_options;

/* in VSD_RECORDS_NEAREST.. and FORM_AUTO.. order */
static const char *const interp_names[] = {"nearest", "trilinear", "log", NULL};
static const char *const form_names[] = {"auto", "factored", "product", NULL};

static const char *healpix_count_problem(double v)
{
    return vsd_sh_healpix_nside((long)v) ? NULL : "is not a HEALPix pixel count 12 nside^2 (12, 48, 108, 192, 300, ...)";
}

typedef struct shgrid_state {
    shgrid_options opt;
    long dirs_count, nside;  /* opt.directions and its HEALPix nside */
    /* HEALPix directions and their basis rows (fixed per renderer) */
    float *dirs, *basis, *dir_radiance;
    /* frame: the record grid */
    vsd_record_grid rg;
    vsd_density_levels levels;   /* the density the records' rays read, per volume */
    float *trans;            /* [records * n2] SH of transmittance, when have_trans */
    int have_trans;
    float *rgb;              /* [records * 3 n2] SH of T*L (RGB kind) */
    float *baked;            /* [records * 3] in-scattered RGB per unit sigma_s (BAKED kind) */
    int kind;                /* what render uses */
    /* lighting */
    float light[3 * VSD_SH_MAX_COEFFS];
    double env_tex[3 * VSD_SH_MAX_COEFFS];   /* env SH in texture frame, unit strength */
    double env_sum;          /* content checksum of the projected map (pointers get reused) */
    int env_w, env_h, have_env;
    /* extension: the map split into extracted lights + the remainder the SH carries */
    vsd_env rest;            /* the map without its extracted texels (rgb owned here) */
    vsd_light_constellation bright;   /* lights standing for the extracted texels, texture frame */
    double bright_fraction;  /* luminance share of the map taken out of the SH */
    float klights[8 * VSD_RECORDS_MAX_LIGHTS];   /* kernel lights (world, strength applied) */
    int light_count;
    float *light_trans;      /* [records * light_count] */
    int have_light_trans;
    float light_trans_rot;   /* rotation_z the light transmittances were marched for */
    vsd_sh_tensor *tensor;
    double frame_seconds, lighting_seconds;
    /* several volumes: a part per volume, its records over its own box, their rays marched
     * through every volume (src/method/method_parts.h, kernel_volumes.h) */
    vsd_method_parts parts;
} shgrid_state;

/* The bright texels are split off only when there are lights to take them. */
static const vsd_option_when shgrid_on_lights[] = {{"lights", 1, 0, NULL}, {NULL, 0, 0, NULL}};

static const vsd_option_spec shgrid_option_rows[] = {
    {"grid", VSD_OPT_INT, 1, 256, 0, NULL,
     "record cells per axis over the density's box, the paper's N (0 = a cell per 4 voxels of the longest axis, 32..64)",
     offsetof(shgrid_options, grid), VSD_OPT_ZERO_AUTO, NULL, NULL},
    {"order", VSD_OPT_INT, 1, VSD_SH_MAX_ORDER, SHGRID_DEFAULT_ORDER, NULL, "spherical-harmonic order (order^2 coefficients)",
     offsetof(shgrid_options, order), 0, NULL, NULL},
    {"directions", VSD_OPT_INT, 12, 196608, 192, NULL, "HEALPix directions each record marches toward (12 nside^2)",
     offsetof(shgrid_options, directions), 0, healpix_count_problem, NULL},
    {"probes", VSD_OPT_INT, 0, 16, 3, NULL, "k: k^3 density probes per cell decide whether it is empty (0 = keep cells over non-empty bricks)",
     offsetof(shgrid_options, probes), 0, NULL, NULL},
    {"interpolation", VSD_OPT_CHOICE, 0, 0, VSD_RECORDS_LOG_TRILINEAR, interp_names,
     "record lookup: nearest cell (the paper), trilinear, or trilinear in log radiance",
     offsetof(shgrid_options, interp), 0, NULL, NULL},
    {"form", VSD_OPT_CHOICE, 0, 0, FORM_AUTO, form_names,
     "factored (isotropic phase, fast relighting) or product (RGB records); auto picks by anisotropy",
     offsetof(shgrid_options, form), 0, NULL, NULL},
    {"step", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "view march step, world units (0 = the smallest voxel)",
     offsetof(shgrid_options, step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    {"record_step", VSD_OPT_NUMBER, 0, 1e30, 0, NULL,
     "record march step, world units (0 = a voxel, or a cell where the records read a coarser density)",
     offsetof(shgrid_options, record_step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    {"record_density", VSD_OPT_CHOICE, 0, 0, VSD_DENSITY_AUTO, vsd_density_choice_names,
     "density the records' rays read: auto (the coarsest 2x-reduced level whose voxel fits in a cell and that keeps "
     "the data's detail) or full (the source voxels)",
     offsetof(shgrid_options, record_density), 0, NULL, NULL},
    VSD_OPTION_PIXEL_SAMPLES(shgrid_options),
    VSD_OPTION_EARLY_TERMINATION(shgrid_options, "view ray"),
    VSD_OPTION_VIEW_SPACING(shgrid_options, view.spacing, view.threshold),
    {"view_bake", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "CPU view with an anisotropic phase: the SH records and the lights' term toward the camera once per view and "
     "record, the phase at the camera-to-record direction, as lbl's and constellation's (false = evaluated per record "
     "a ray crosses, the phase at the ray's direction)",
     offsetof(shgrid_options, view_bake), 0, NULL, NULL},
    {"lights", VSD_OPT_INT, 0, VSD_RECORDS_MAX_LIGHTS, SHGRID_DEFAULT_LIGHTS, NULL,
     "bright texels taken out of the SH as exact lights (0 = the paper's pure SH form)",
     offsetof(shgrid_options, lights), 0, NULL, NULL},
    {"light_threshold", VSD_OPT_NUMBER, 1, 1e30, SHGRID_DEFAULT_LIGHT_THRESHOLD, NULL,
     "texels brighter than this multiple of the map's mean luminance become lights",
     offsetof(shgrid_options, light_threshold), 0, NULL, .when = shgrid_on_lights},
};

static vsd_status shgrid_create(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen)
{
    const shgrid_options *o = options;
    shgrid_state *s;
    (void)scene;
    s = calloc(1, sizeof *s);
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *o;
    s->dirs_count = o->directions;
    s->nside = vsd_sh_healpix_nside(s->dirs_count);
    /* the HEALPix directions and the basis at them, weighted 4pi/M, once */
    {
        int n2 = s->opt.order * s->opt.order;
        long j;
        double *d = malloc(sizeof(double) * 3 * (size_t)s->dirs_count);
        s->dirs = malloc(sizeof(float) * 4 * (size_t)s->dirs_count);
        s->basis = malloc(sizeof(float) * (size_t)n2 * (size_t)s->dirs_count);
        s->dir_radiance = calloc(4 * (size_t)s->dirs_count, sizeof(float));
        if (!d || !s->dirs || !s->basis || !s->dir_radiance) {
            long count = s->dirs_count;
            free(d);
            free(s->dirs); free(s->basis); free(s->dir_radiance); free(s);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %ld directions", count);
        }
        vsd_sh_healpix_dirs(s->nside, d, NULL, 0);
        for (j = 0; j < s->dirs_count; j++) {
            double y[VSD_SH_MAX_COEFFS];
            int i;
            vsd_sh_eval(s->opt.order, d + 3 * j, y);
            for (i = 0; i < 3; i++) s->dirs[4 * j + i] = (float)d[3 * j + i];
            s->dirs[4 * j + 3] = 0.0f;
            for (i = 0; i < n2; i++) s->basis[j * n2 + i] = (float)(y[i] * 4.0 * VSD_PI / (double)s->dirs_count);
        }
        free(d);
    }
    *state = s;
    return VSD_OK;
}

static void free_frame(shgrid_state *s)
{
    vsd_record_grid_free(&s->rg);
    vsd_density_levels_free(&s->levels);
    free(s->trans); free(s->rgb); free(s->light_trans); free(s->baked);
    s->trans = NULL; s->rgb = NULL; s->light_trans = NULL; s->baked = NULL;
    s->have_trans = 0;
    s->have_light_trans = 0;
}

/* The kernel view of the state for the current stage. */
static void kernel_grid(const shgrid_state *s, const vsd_kernel_data *kd, int kind, vsd_krecord_grid *g)
{
    memset(g, 0, sizeof *g);
    g->kd = kd;
    g->cell_record = s->rg.cell_record;
    g->records = kind == VSD_RECORDS_SH_SCALAR ? s->trans : kind == VSD_RECORDS_BAKED ? s->baked : s->rgb;
    g->record_pos = s->rg.record_pos;
    g->dirs = s->dirs;
    g->basis = s->basis;
    g->dir_radiance = s->dir_radiance;
    g->light = s->light;
    g->lights = s->klights;
    g->light_trans = s->light_trans;
    g->light_count = s->light_count;
    g->world_to_grid = s->rg.world_to_grid;
    memcpy(g->res, s->rg.res, sizeof g->res);
    g->order = s->opt.order;
    g->n2 = s->opt.order * s->opt.order;
    g->kind = kind;
    g->stride = kind == VSD_RECORDS_SH_SCALAR ? g->n2 : kind == VSD_RECORDS_BAKED ? 3 : 3 * g->n2;
    /* baked records already hold the extracted lights' term */
    if (kind == VSD_RECORDS_BAKED) g->light_count = 0;
    g->interp = s->opt.interp;
    g->dir_count = (int32_t)s->dirs_count;
    g->record_count = s->rg.count;
    g->record_step = (float)(s->opt.record_step > 0 ? s->opt.record_step
                             : s->levels.step > 0 ? s->levels.step : 2.0 * kd->density.step);
}

typedef struct record_job { const vsd_krecord_grid *g; float *out; int lights; } record_job;

static void record_tile(void *user, int x0, int y0, int x1, int y1)
{
    record_job *j = user;
    int r;
    (void)y0; (void)y1;
    for (r = x0; r < x1; r++) {
        if (j->lights) vsd_shgrid_light_record(j->g, r, j->out + (size_t)r * j->g->light_count);
        else vsd_shgrid_record(j->g, r, j->out + (size_t)r * j->g->stride);
    }
}

/* The record pass over every record on the CPU threads (records are the tile job's x):
 * kind VSD_RECORDS_SH_SCALAR / RGB for the SH records, PASS_LIGHTS for the transmittance
 * toward the extracted lights. */
static vsd_status run_records(shgrid_state *s, const vsd_frame_ctx *ctx, int kind, char *err, size_t errlen)
{
    vsd_krecord_grid g;
    record_job job;
    vsd_tile_job tj;
    vsd_status st;
    vsd_kernel_data coarse;
    vsd_kobject coarse_objects[VSD_KMAX_VOLUMES];
    if (s->rg.count == 0) return VSD_OK;
    /* the rays read each volume at the records' resolution (src/method/density_levels.h) */
    vsd_density_levels_kd(&s->levels, &ctx->kd, &coarse, coarse_objects);
    kernel_grid(s, &coarse, kind == PASS_LIGHTS ? VSD_RECORDS_SH_SCALAR : kind, &g);
    job.g = &g;
    job.lights = kind == PASS_LIGHTS;
    job.out = job.lights ? s->light_trans : kind == VSD_RECORDS_SH_SCALAR ? s->trans : s->rgb;
    /* the paper's per-frame GPU pass: one thread per record, results copied back. Rays that
       read a coarser density level run on the CPU threads (the device holds the source
       voxels only; a device copy of the levels is future work), so both backends give the
       same records */
    if (ctx->cuda && !vsd_density_levels_any(&s->levels))
        return vsd_shgrid_device_records(ctx, &g, job.lights, job.out, err, errlen);
    vsd_method_item_job(&tj, ctx, s->rg.count, record_tile, &job, job.lights ? "light transmittance" : "record grid");
    st = vsd_cpu_run_tiles(&tj);
    if (st == VSD_ERR_CANCELLED) return vsd_fail(st, err, errlen, "render cancelled");
    return st;
}

static int want_product(const shgrid_state *s, const vsd_frame_ctx *ctx)
{
    if (s->opt.form == FORM_PRODUCT) return 1;
    if (s->opt.form == FORM_FACTORED) return 0;
    return ctx->kd.medium.anisotropy != 0.0f;
}

/* grid = 0: about 4 voxels per cell along the volume's longest axis, 32 to 64 cells. A
 * fixed 32 spread 7 voxels over a cell of a 223-voxel Houdini smoke, where the records'
 * interpolation blurred the self-shadowing (docs/methods/shgrid.md, "Large volumes"). */
static int auto_grid(const vsd_kvolume *v)
{
    int longest, shortest, cells;
    vsd_kvolume_brick_extent(v, &longest, &shortest);
    cells = (longest + 3) / 4;
    return cells < 32 ? 32 : cells > 64 ? 64 : cells;
}

static vsd_status shgrid_prepare_frame(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    shgrid_state *s = state;
    const vsd_kvolume *v = &ctx->kd.density;
    int n2 = s->opt.order * s->opt.order;
    vsd_status st;
    free_frame(s);
    if (!ctx->part.active) {
        if (ctx->kd.volume_count > 1)
            /* every volume: the records' transmittance marches through all of them */
            return vsd_parts_prepare_frame(&s->parts, &vsd_method_shgrid, &s->opt, NULL, ctx, err, errlen);
        vsd_parts_free(&s->parts, &vsd_method_shgrid);
    }
    if ((st = vsd_record_grid_build(v, s->opt.grid > 0 ? s->opt.grid : auto_grid(v), s->opt.probes, &s->rg, err, errlen)))
        return st;
    if ((st = vsd_density_levels_for_grid(&s->levels, ctx, &s->rg, s->opt.record_density, err, errlen))) return st;
    s->trans = malloc(sizeof(float) * (size_t)n2 * (size_t)(s->rg.count ? s->rg.count : 1));
    s->rgb = malloc(sizeof(float) * 3 * (size_t)n2 * (size_t)(s->rg.count ? s->rg.count : 1));
    if (!s->trans || !s->rgb) {
        free_frame(s);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d SH records", s->rg.count);
    }
    /* the volume-dependent factor, when the lighting will not be baked into the records */
    if (!want_product(s, ctx)) {
        if ((st = run_records(s, ctx, VSD_RECORDS_SH_SCALAR, err, errlen))) return st;
        s->have_trans = 1;
    }
    return VSD_OK;
}

/* Extension (shgrid_kernel.h): the map's texels above light_threshold times its mean
 * luminance as at most `lights` median-cut lights, the remainder (s->rest) what the SH
 * projections see (src/lighting/env_bright.h). */
static vsd_status split_env(shgrid_state *s, const vsd_env *env, char *err, size_t errlen)
{
    vsd_constellation_free(&s->bright);
    free(s->rest.rgb);
    s->rest.rgb = NULL;
    return vsd_env_split_bright(env, s->opt.light_threshold, s->opt.lights, &s->rest, &s->bright, &s->bright_fraction,
                                err, errlen);
}

/* Isotropic phase: each record's in-scattered radiance (SH term plus the extracted
 * lights' term) is the same for every view direction, so the lighting stage evaluates it
 * once per record with the view pass's own function, and the view pass reads it. */
static vsd_status bake_isotropic(shgrid_state *s, const vsd_kernel_data *kd, char *err, size_t errlen)
{
    vsd_krecord_grid g;
    vsd_status st;
    free(s->baked);
    s->baked = NULL;
    kernel_grid(s, kd, VSD_RECORDS_SH_SCALAR, &g);
    if ((st = vsd_record_grid_bake(&g, &s->baked, err, errlen))) return st;
    s->kind = VSD_RECORDS_BAKED;
    return VSD_OK;
}

static vsd_status shgrid_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    shgrid_state *s = state;
    const vsd_scene *sc = ctx->scene;
    int n2 = s->opt.order * s->opt.order, i, c, env_changed = 0;
    const vsd_env *sh_env = ctx->env;
    vsd_status st;
    if (s->parts.count) return vsd_parts_prepare_lighting(&s->parts, &vsd_method_shgrid, ctx, err, errlen);
    /* F_Ind: the environment's SH, projected once per map (texture frame) and rotated about
     * Z for Blender's Mapping rotation, so turning the map costs one SH rotation */
    {
        double sum = 0.0;
        size_t k, n = (size_t)ctx->env->width * ctx->env->height * 3;
        for (k = 0; k < n; k++) sum += (double)ctx->env->rgb[k] * (double)(1 + (k % 7));
        if (!s->have_env || sum != s->env_sum || s->env_w != ctx->env->width || s->env_h != ctx->env->height) {
            s->have_env = 0;
            env_changed = 1;
            if (s->opt.lights > 0 && (st = split_env(s, ctx->env, err, errlen))) return st;
            st = vsd_sh_project_env(s->opt.order, s->opt.lights > 0 ? &s->rest : ctx->env, 1.0, 0.0, s->env_tex, err, errlen);
            if (st) return st;
            s->env_sum = sum;
            s->env_w = ctx->env->width;
            s->env_h = ctx->env->height;
            s->have_env = 1;
        }
    }
    {
        double rz = sc->environment.rotation_z, R[9] = {cos(rz), sin(rz), 0, -sin(rz), cos(rz), 0, 0, 0, 1};
        double out[VSD_SH_MAX_COEFFS];
        vsd_sh_rotation rot;
        vsd_sh_rotation_init(&rot, s->opt.order, R);   /* world = Rz(-rotation) texture */
        for (c = 0; c < 3; c++) {
            vsd_sh_rotate(&rot, s->env_tex + c * n2, out);
            for (i = 0; i < n2; i++) s->light[c * n2 + i] = (float)(out[i] * sc->environment.strength);
        }
    }
    if (s->opt.lights > 0) sh_env = &s->rest;
    /* extension: the extracted lights for this strength and rotation; the transmittance
     * toward them is re-marched when their directions move (new frame, map or rotation) */
    s->light_count = s->opt.lights > 0 ? s->bright.count : 0;
    if (s->light_count > 0)
        vsd_constellation_kernel_lights(&s->bright, sc->environment.strength, sc->environment.rotation_z, s->klights);
    if (s->rg.count == 0) {
        s->kind = VSD_RECORDS_SH_SCALAR;
        return VSD_OK;
    }
    if (s->light_count > 0 &&
        (env_changed || !s->have_light_trans || s->light_trans_rot != sc->environment.rotation_z)) {
        free(s->light_trans);
        s->have_light_trans = 0;
        s->light_trans = malloc(sizeof(float) * (size_t)s->rg.count * (size_t)s->light_count);
        if (!s->light_trans) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for the light transmittances");
        if ((st = run_records(s, ctx, PASS_LIGHTS, err, errlen))) return st;
        s->have_light_trans = 1;
        s->light_trans_rot = sc->environment.rotation_z;
    }
    if (want_product(s, ctx)) {
        /* §4.4 static-media form: T*L per HEALPix direction, projected per record */
        vsd_env_healpix_radiance(sh_env, &ctx->kd.env, s->nside, s->dir_radiance);
        s->kind = VSD_RECORDS_SH_RGB;
        return run_records(s, ctx, VSD_RECORDS_SH_RGB, err, errlen);
    }
    if (!s->have_trans) {
        if ((st = run_records(s, ctx, VSD_RECORDS_SH_SCALAR, err, errlen))) return st;
        s->have_trans = 1;
    }
    if (ctx->kd.medium.anisotropy == 0.0f) return bake_isotropic(s, &ctx->kd, err, errlen);
    /* factored form with an anisotropic phase: (T * L) per record by the triple product,
     * then the view pass convolves with HG */
    if (!s->tensor && (st = vsd_sh_tensor_create(s->opt.order, &s->tensor, err, errlen))) return st;
    {
        int r;
        double t[VSD_SH_MAX_COEFFS], l[VSD_SH_MAX_COEFFS], o[VSD_SH_MAX_COEFFS];
        for (r = 0; r < s->rg.count; r++) {
            for (i = 0; i < n2; i++) t[i] = s->trans[(size_t)r * n2 + i];
            for (c = 0; c < 3; c++) {
                for (i = 0; i < n2; i++) l[i] = s->light[c * n2 + i];
                vsd_sh_triple(s->tensor, t, l, o);
                for (i = 0; i < n2; i++) s->rgb[(size_t)r * 3 * n2 + c * n2 + i] = (float)o[i];
            }
        }
    }
    s->kind = VSD_RECORDS_SH_RGB;
    return VSD_OK;
}

/* a part's record grid (src/method/method_parts.h) */
static vsd_status view_part(void *state, vsd_frame_ctx *ctx, vsd_krecord_grid *g, char *err, size_t errlen)
{
    const shgrid_state *s = state;
    (void)err;
    (void)errlen;
    kernel_grid(s, &ctx->kd, s->kind, g);
    return VSD_OK;
}

static vsd_status shgrid_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                                char *err, size_t errlen)
{
    shgrid_state *s = state;
    vsd_krecord_grid g;
    if (s->parts.count)
        return vsd_parts_render(&s->parts, view_part, ctx, fb, s->opt.pixel_samples, s->opt.step,
                                s->opt.early_termination, &s->opt.view, samples, err, errlen);
    kernel_grid(s, &ctx->kd, s->kind, &g);
    if (ctx->info && ctx->info_len)
        snprintf(ctx->info, ctx->info_len, "cells=%dx%dx%d records=%d density_level=%d density_level_seconds=%.3f",
                 s->rg.res[0], s->rg.res[1], s->rg.res[2], s->rg.count, s->levels.level[0], s->levels.seconds);
    if (g.kind == VSD_RECORDS_SH_RGB && s->opt.view_bake && !ctx->cuda)
        /* Why: a view ray evaluated each record it crossed, an order-n SH dot product per
           colour and the lights' phase per corner, most of the camera change on smoke128
           (g = 0.2); once per record and view it is 3 floats a corner (docs/methods/shgrid.md).
           (An isotropic phase was baked once per lighting: the BAKED kind.) */
        return vsd_record_grid_render_baked(ctx, fb, &g, s->rg.record_pos, s->opt.pixel_samples, s->opt.step,
                                            s->opt.early_termination, &s->opt.view, samples, err, errlen);
    return vsd_record_grid_render(ctx, fb, &g, s->opt.pixel_samples, s->opt.step, s->opt.early_termination, &s->opt.view, samples,
                                  err, errlen);
}

static void shgrid_destroy(void *state)
{
    shgrid_state *s = state;
    if (!s) return;
    vsd_parts_free(&s->parts, &vsd_method_shgrid);
    free_frame(s);
    free(s->dirs);
    free(s->basis);
    free(s->dir_radiance);
    vsd_sh_tensor_destroy(s->tensor);
    vsd_constellation_free(&s->bright);
    free(s->rest.rgb);
    free(s);
}

const vsd_method vsd_method_shgrid = {
    .name = "shgrid",
    .label = "SH Grid",
    .summary = "Delalandre 2013: spherical-harmonics record grid",
    .caps = VSD_METHOD_CAP_CUDA_VIEW | VSD_METHOD_CAP_SEVERAL_VOLUMES,
    .roles = 0,
    .options = VSD_OPTION_TABLE(shgrid_option_rows, shgrid_options),
    .create = shgrid_create,
    .prepare_frame = shgrid_prepare_frame,
    .prepare_lighting = shgrid_prepare_lighting,
    .render = shgrid_render,
    .destroy = shgrid_destroy,
};
