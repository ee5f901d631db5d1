/* method.h — the interface every rendering method implements (docs/architecture.md §5), and the frame
 * context the renderer hands it. Methods live in core/methods/<name>/.
 *
 * Life cycle, driven by renderer.c:
 *   create()             once per renderer, with the option struct that `options` (the
 *                        method's table, method_options.h) filled from render.options
 *   prepare_frame()      when the volume frame changes (new file or medium density)
 *   prepare_lighting()   when the environment, its rotation/strength or the medium changes
 *   render()             per view: fills the framebuffer
 *   destroy()
 * Any hook may be NULL when a method has nothing to do at that stage. */
#ifndef VSD_METHOD_H
#define VSD_METHOD_H
#include "vsd/render.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "kernel/kernel_types.h"
#include "method_options.h"
#include "methods/registry.h"

struct vsd_radiance_cache;

/* Everything a method may read while preparing or rendering one frame. */
typedef struct vsd_frame_ctx {
    const vsd_scene *scene;
    int volume_count;                   /* the scene's volumes; kd.volumes holds them all. A
                                           method without VSD_METHOD_CAP_SEVERAL_VOLUMES only
                                           ever sees 1 (the renderer refuses the rest) */
    /* volume 0's grids: */
    const vsd_volume *density;          /* never NULL (empty volume when the grid is empty) */
    const vsd_volume *emission;         /* NULL when no emission grid */
    /* every volume's (volume_count of them; [0] = density, emission above) */
    const vsd_volume *volume_density[VSD_KMAX_VOLUMES];
    const vsd_volume *volume_emission[VSD_KMAX_VOLUMES];
    /* every volume's volume.ior_grid grid (of n or of temperature), or NULL */
    const vsd_volume *volume_ior[VSD_KMAX_VOLUMES];
    /* every volume's frame inputs (its files and frame, grids, density scale, ior, matrix)
     * as a hash: an unchanged key is an unchanged volume for the frame stage */
    uint64_t volume_key[VSD_KMAX_VOLUMES];
    const vsd_env *env;
    vsd_kernel_data kd;                 /* host pointers; method fills lights/march_step */
    int threads;
    vsd_progress_fn progress;
    void *user;
    volatile int *cancel;
    /* The CUDA backend when this frame runs on the GPU, else NULL. Arrays a method keeps
     * on the device are keyed by the generation of the stage that made them: frame_gen
     * changes whenever prepare_frame runs, lighting_gen whenever prepare_lighting runs
     * (so also on every new frame, already while prepare_frame runs); volume_gen and
     * env_gen change only with the loaded volumes or environment map themselves. */
    struct vsd_cuda *cuda;
    uint64_t frame_gen, lighting_gen, volume_gen, env_gen;
    const char *cache_dir;              /* vsd_render_options.cache_dir, NULL = none */
    struct vsd_accum_store *accum_store; /* the renderer's memory for a view's sums (accum.h) */
    char *info;                         /* vsd_render_stats.method_info: render() may fill it */
    size_t info_len;
    /* Several volumes, a record-grid method's part (src/method/method_parts.h): active = 1
     * when this context is volume `volume`'s, standing as volume 0, lighting the volumes of
     * `group` (bit i = volume i). 0 in the renderer's own context. */
    struct {
        int active, volume;
        uint32_t group;
    } part;
} vsd_frame_ctx;

/* What a method can render, for the menus and warnings of its users (the add-on reads them
 * from HELLO, `vsd methods --json` prints them): the public VSD_METHOD_CAP_* bits
 * (vsd/render.h). Roles: which method a new scene or a new viewport uses. */
enum { VSD_METHOD_ROLE_FINAL_DEFAULT = 1u << 0, VSD_METHOD_ROLE_VIEWPORT_DEFAULT = 1u << 1 };

typedef struct vsd_method {
    const char *name;
    const char *label;                 /* for menus: "Reference", "LBL" */
    const char *summary;               /* one line: the paper and what it does */
    unsigned caps;                     /* VSD_METHOD_CAP_* */
    unsigned roles;                    /* VSD_METHOD_ROLE_* */
    /* render.options for a quick first look at a changed scene, as a JSON object of this
     * method's own keys (NULL: none): the add-on's viewport renders its first, 1/N-size pass
     * of a material edit or a new frame with them while the full lighting is still to come
     * (issue 32: the lighting stage, not the view, is what a material edit waits for). */
    const char *preview_options;
    vsd_option_table options;          /* render.options: the one table of keys, types, ranges */
    vsd_status (*create)(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen);
    vsd_status (*prepare_frame)(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen);
    vsd_status (*prepare_lighting)(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen);
    vsd_status (*render)(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                         char *err, size_t errlen);
    void (*destroy)(void *state);
    /* 1: renders refraction in a scene of several volumes where one of them refracts (the
     * others' rays bend through that one's field; vsd_method_check_volumes) */
    int refraction_among_volumes;
    /* 1: the frame stage reads only whether the medium's density is > 0, the lighting stage
     * its value (one volume): an edit of medium.density re-lights without preparing the
     * frame again (issue 32: a density edit in the viewport). 0: density is a frame key. */
    int density_in_lighting;
    /* After the lighting stage: the method's light scattered at least once, as a P1 radiance
     * field for `reference`'s control variate (render.options.cache, issue 33;
     * src/lighting/radiance_cache.h), with the frame it was lit for (the medium and the
     * volume's transform, which the method need not keep for this). NULL for a method that
     * has no multiple scattering to give. */
    vsd_status (*radiance_cache)(void *state, const vsd_frame_ctx *ctx, struct vsd_radiance_cache *out, char *err,
                                 size_t errlen);
} vsd_method;

/* Whether m renders sc's volumes[]: an error naming the methods that do when there are
 * several and m renders one, or when one of several volumes refracts. */
vsd_status vsd_method_check_volumes(const vsd_method *m, const vsd_scene *sc, char *err, size_t errlen);
/* Whether m renders sc's lights[]: an error naming the methods that do when it does not,
 * or when the lights would have to shine through a refracting medium. */
vsd_status vsd_method_check_lights(const vsd_method *m, const vsd_scene *sc, char *err, size_t errlen);

/* Every method of the registry (core/methods/registry.h) is declared here. */
#define VSD_METHOD_DECLARE(name) extern const vsd_method vsd_method_##name;
VSD_METHOD_REGISTRY(VSD_METHOD_DECLARE)
#undef VSD_METHOD_DECLARE

const vsd_method *vsd_method_find(const char *name);

/* A CPU tile job over fb for this frame: threads, progress (whole stage, span 1) and cancel
 * come from ctx. Methods adjust progress_base/span for multi-round passes. */
struct vsd_tile_job;
void vsd_method_tile_job(struct vsd_tile_job *job, const vsd_frame_ctx *ctx, const vsd_framebuffer *fb,
                         void (*fn)(void *, int, int, int, int), void *user, const char *stage);

/* A CPU job over `count` items (records of a record grid): fn gets item ranges as the
 * x range of a count x 1 image. */
void vsd_method_item_job(struct vsd_tile_job *job, const vsd_frame_ctx *ctx, int count,
                         void (*fn)(void *, int, int, int, int), void *user, const char *stage);

/* Read scene->render.options_json against m->options into a new option struct (free()
 * it): an unknown key, wrong type or out-of-range value is an error naming it. */
vsd_status vsd_method_parse_options(const vsd_method *m, const vsd_scene *scene, void **options, char *err,
                                    size_t errlen);
/* The same from options_json (NULL: every default), e.g. a method another one runs inside
 * it with its own defaults (reference's cache). */
vsd_status vsd_method_options_from_json(const vsd_method *m, const char *options_json, void **options, char *err,
                                        size_t errlen);

/* A method's kernel struct with its arrays on ctx's device: fills dev (the pass's
 * struct_bytes) from the host struct `host`, arrays replaced by resident device copies. */
typedef vsd_status (*vsd_device_struct_fn)(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err,
                                           size_t errlen);

/* The whole view pass of a deterministic method: n x n stratified rays per pixel, each
 * pass->sample(kernel, x, y, s, n), on CPU tiles, or on ctx->cuda through the same pass
 * (to_device makes the device struct; NULL when the pass reads kd only and kernel is
 * &ctx->kd); resolved into fb; *samples = n * n. One loop for every such method, so the
 * pixel filter (a box, like the reference's) is the same everywhere. */
struct vsd_device_pass;
vsd_status vsd_method_render_stratified(vsd_frame_ctx *ctx, vsd_framebuffer *fb, int n,
                                        const struct vsd_device_pass *pass, vsd_device_struct_fn to_device,
                                        const void *kernel, int *samples, char *err, size_t errlen);

/* Adaptive view sampling (adaptive_view.c): spacing s > 1 traces every s-th pixel first and
 * interpolates the blocks between them whose anchors agree within `threshold`; 1 traces
 * every pixel; 0 picks s from the film's resolution against the volume's
 * (vsd_view_auto_spacing: 1 where a voxel covers under 3 pixels). CPU only: a device pass
 * traces every pixel. */
#define VSD_VIEW_SPACING_MAX 8   /* view_spacing's largest value */
typedef struct vsd_view_sampling {
    int spacing;
    double threshold;
} vsd_view_sampling;
#define VSD_OPTION_VIEW_SPACING(type, field_spacing, field_threshold) \
    VSD_OPTION_VIEW_SPACING_WHEN(type, field_spacing, field_threshold, NULL, vsd_option_on_sparse_view)
/* The same rows where the adaptive view serves one of a method's view modes: view_spacing
 * applies when `when_spacing` holds, view_threshold when `when_threshold` does (those
 * conditions and view_spacing != 1). */
#define VSD_OPTION_VIEW_SPACING_WHEN(type, field_spacing, field_threshold, when_spacing, when_threshold) \
    {"view_spacing", VSD_OPT_INT, 0, VSD_VIEW_SPACING_MAX, 0, NULL, \
     "CPU view: trace every n-th pixel first and interpolate between them where they agree (1 = trace all; " \
     "0 = from the film's resolution against the volume's: 2/3 of a voxel's footprint, at most 4)", \
     offsetof(type, field_spacing), VSD_OPT_ZERO_AUTO, NULL, .when = when_spacing}, \
    {"view_threshold", VSD_OPT_NUMBER, 0, 1, 0.15, NULL, \
     "with view_spacing > 1: trace a block when its corner pixels differ by more than this (relative)", \
     offsetof(type, field_threshold), 0, NULL, .when = when_threshold}
/* view_threshold's rule: it decides nothing when every pixel is traced (view_spacing 1). */
extern const vsd_option_when vsd_option_on_sparse_view[];
int vsd_view_auto_spacing(const vsd_frame_ctx *ctx);
/* The same as vsd_method_render_stratified with adaptive sampling vs (NULL = every pixel);
 * ctx->info gets " view_traced=<pixels traced per pixel of the film>" appended when it applies. A pass
 * with no device entry (several volumes, so far) runs on the CPU threads even when the frame
 * has a device. */
vsd_status vsd_method_render_view(vsd_frame_ctx *ctx, vsd_framebuffer *fb, int n, const vsd_view_sampling *vs,
                                  const struct vsd_device_pass *pass, vsd_device_struct_fn to_device,
                                  const void *kernel, int *samples, char *err, size_t errlen);

/* World-space march step: `option` when > 0, else half the smallest voxel of the density
 * grid (of the emission grid when there is no density). */
float vsd_method_march_step(const vsd_frame_ctx *ctx, double option);
/* The same for any kernel data (a method's own copy, e.g. at a coarser density level). */
float vsd_kd_march_step(const vsd_kernel_data *kd, double option);

#endif
