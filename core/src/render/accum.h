/* accum.h — per-pixel sums of sample results (double precision, so thousands of samples
 * add up without drift) and their resolution into the framebuffer's passes. Every method
 * that produces vsd_sample_result values goes through this, so the pass definitions
 * (Combined = Dir + Ind + Emit [+ background], alpha = 1 - T, Depth = mean first-collision
 * distance) exist once. */
#ifndef VSD_ACCUM_H
#define VSD_ACCUM_H
#include "vsd/image.h"
#include "kernel/kernel_accum.h"

/* Memory a renderer keeps for its views' sums (renderer.c), reused view after view: the
 * sums of a 1280x720 view are 110 MB, which a fresh calloc faults in page by page (70 ms
 * on the 2-core VM, more than zeroing it again on the CPU threads). */
typedef struct vsd_accum_store {
    double *v;
    size_t doubles;
} vsd_accum_store;
void vsd_accum_store_free(vsd_accum_store *s);

typedef struct vsd_accum {
    int width, height;
    double *v;        /* [width*height*VSD_ACC_N] */
    int borrowed;     /* v is a store's */
} vsd_accum;

/* Zeroed sums for a width x height view: in store's memory (grown when too small) zeroed on
 * `threads` CPU threads (0 = all), or in a buffer of their own when store is NULL. */
vsd_status vsd_accum_init(vsd_accum *a, vsd_accum_store *store, int threads, int width, int height, char *err,
                          size_t errlen);
void vsd_accum_free(vsd_accum *a);
void vsd_accum_add(vsd_accum *a, int x, int y, const vsd_sample_result *r);
/* The adaptive view (adaptive_view.c): acc filled for vs->spacing > 1 on the CPU threads;
 * *traced_permille = the pixels traced (anchors included) per thousand pixels of the film. */
struct vsd_frame_ctx;
struct vsd_view_sampling;
struct vsd_device_pass;
vsd_status vsd_adaptive_view(struct vsd_frame_ctx *ctx, vsd_accum *acc, int n, const struct vsd_view_sampling *vs,
                             const struct vsd_device_pass *pass, const void *kernel, int *traced_permille, char *err,
                             size_t errlen);
/* Write the mean over `samples` samples per pixel into fb, on `threads` CPU threads. */
void vsd_accum_resolve(const vsd_accum *a, int samples, int transparent, int threads, vsd_framebuffer *fb);

#endif
