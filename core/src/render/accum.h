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
/* The same sums uncleared, for a writer that sets every sum it reads (the adaptive view). */
vsd_status vsd_accum_borrow(vsd_accum *a, vsd_accum_store *store, int width, int height, char *err, size_t errlen);
void vsd_accum_free(vsd_accum *a);
void vsd_accum_add(vsd_accum *a, int x, int y, const vsd_sample_result *r);
/* The adaptive view (adaptive_view.c) for vs->spacing > 1 on the CPU threads: every pixel
 * of fb resolved as it is traced or interpolated (no pass over the whole film's sums
 * after it); acc (vsd_accum_borrow: uncleared) keeps the sums of the traced pixels, which
 * the blocks read back from one another. *traced_permille = the pixels traced (anchors
 * included) per thousand pixels of the film. */
struct vsd_frame_ctx;
struct vsd_view_sampling;
struct vsd_device_pass;
vsd_status vsd_adaptive_view(struct vsd_frame_ctx *ctx, vsd_accum *acc, vsd_framebuffer *fb, int n,
                             const struct vsd_view_sampling *vs,
                             const struct vsd_device_pass *pass, const void *kernel, int *traced_permille, char *err,
                             size_t errlen);
/* Pixel i of fb from its sums p over 1/inv samples: every pass of the film (the passes'
 * one definition: the resolve below and the adaptive view's blocks). */
static inline void vsd_accum_resolve_pixel(const double *p, double inv, int transparent, vsd_framebuffer *fb, size_t i)
{
    float *comb = fb->pass[VSD_PASS_COMBINED] + 4 * i;
    float *dir = fb->pass[VSD_PASS_VOLUME_DIR] + 3 * i, *ind = fb->pass[VSD_PASS_VOLUME_IND] + 3 * i;
    float *emit = fb->pass[VSD_PASS_EMIT] + 3 * i, *tr = fb->pass[VSD_PASS_TRANSMITTANCE] + 3 * i;
    const float t = (float)(p[VSD_ACC_T] * inv);
    int c;
    for (c = 0; c < 3; c++) {
        dir[c] = (float)(p[VSD_ACC_DIR + c] * inv);
        ind[c] = (float)(p[VSD_ACC_IND + c] * inv);
        emit[c] = (float)(p[VSD_ACC_EMIT + c] * inv);
        tr[c] = t;
        comb[c] = dir[c] + ind[c] + emit[c] + (transparent ? 0.0f : (float)(p[VSD_ACC_BG + c] * inv));
    }
    comb[3] = transparent ? 1.0f - t : 1.0f;
    fb->pass[VSD_PASS_DEPTH][i] = p[VSD_ACC_DEPTH_N] > 0 ? (float)(p[VSD_ACC_DEPTH] / p[VSD_ACC_DEPTH_N]) : VSD_DEPTH_EMPTY;
}

/* Write the mean over `samples` samples per pixel into fb, on `threads` CPU threads. */
void vsd_accum_resolve(const vsd_accum *a, int samples, int transparent, int threads, vsd_framebuffer *fb);

#endif
