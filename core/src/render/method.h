/* method.h — the interface every rendering method implements (DESIGN.md §5), and the frame
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

/* Everything a method may read while preparing or rendering one frame. */
typedef struct vsd_frame_ctx {
    const vsd_scene *scene;
    const vsd_volume *density;          /* never NULL (empty volume when the grid is empty) */
    const vsd_volume *emission;         /* NULL when no emission grid */
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
} vsd_frame_ctx;

typedef struct vsd_method {
    const char *name;
    vsd_option_table options;          /* render.options: the one table of keys, types, ranges */
    vsd_status (*create)(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen);
    vsd_status (*prepare_frame)(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen);
    vsd_status (*prepare_lighting)(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen);
    vsd_status (*render)(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples,
                         char *err, size_t errlen);
    void (*destroy)(void *state);
} vsd_method;

extern const vsd_method vsd_method_reference;
extern const vsd_method vsd_method_raymarch;
extern const vsd_method vsd_method_shgrid;
extern const vsd_method vsd_method_constellation;

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

/* One ray through pixel (x, y) at sub-pixel position (jx, jy) of a deterministic method;
 * `kernel` is the method's own kernel data. */
typedef vsd_sample_result (*vsd_pixel_fn)(const void *kernel, int x, int y, float jx, float jy);

/* The same view pass on the CUDA device: adds the n x n rays of every pixel into the
 * device sums `accum` (device_frame.h) with the same kernel functions as `fn`. */
struct vsd_cuda_progress;
typedef vsd_status (*vsd_device_pass_fn)(const vsd_frame_ctx *ctx, const void *kernel, int n, double *accum,
                                         const struct vsd_cuda_progress *progress, char *err, size_t errlen);

/* The whole view pass for such a method: n x n stratified rays per pixel on CPU tiles,
 * or through `device_fn` when ctx->cuda is set, resolved into fb; *samples = n * n. */
vsd_status vsd_method_render_stratified(vsd_frame_ctx *ctx, vsd_framebuffer *fb, int n, vsd_pixel_fn fn,
                                        vsd_device_pass_fn device_fn, const void *kernel, const char *stage,
                                        int *samples, char *err, size_t errlen);

/* World-space march step: `option` when > 0, else half the smallest voxel of the density
 * grid (of the emission grid when there is no density). */
float vsd_method_march_step(const vsd_frame_ctx *ctx, double option);

#endif
