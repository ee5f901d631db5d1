/* accum.h — per-pixel sums of sample results (double precision, so thousands of samples
 * add up without drift) and their resolution into the framebuffer's passes. Every method
 * that produces vsd_sample_result values goes through this, so the pass definitions
 * (Combined = Dir + Ind + Emit [+ background], alpha = 1 - T, Depth = mean first-collision
 * distance) exist once. */
#ifndef VSD_ACCUM_H
#define VSD_ACCUM_H
#include "vsd/image.h"
#include "kernel/kernel_accum.h"

typedef struct vsd_accum {
    int width, height;
    double *v;        /* [width*height*VSD_ACC_N] */
} vsd_accum;

vsd_status vsd_accum_init(vsd_accum *a, int width, int height, char *err, size_t errlen);
void vsd_accum_free(vsd_accum *a);
void vsd_accum_add(vsd_accum *a, int x, int y, const vsd_sample_result *r);
/* The adaptive view (adaptive_view.c): acc filled for vs->spacing > 1 on the CPU threads;
 * *traced_permille = the share of blocks traced ray by ray. */
struct vsd_frame_ctx;
struct vsd_view_sampling;
struct vsd_device_pass;
vsd_status vsd_adaptive_view(struct vsd_frame_ctx *ctx, vsd_accum *acc, int n, const struct vsd_view_sampling *vs,
                             const struct vsd_device_pass *pass, const void *kernel, int *traced_permille, char *err,
                             size_t errlen);
/* Write the mean over `samples` samples per pixel into fb. */
void vsd_accum_resolve(const vsd_accum *a, int samples, int transparent, vsd_framebuffer *fb);

#endif
