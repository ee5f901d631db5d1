/* constellation_device.h — the constellation's view on the CUDA device of ctx: the
 * distance maps, dense grid and lights resident (frame/lighting generations), the
 * validity-mask pass and the lighting pass launched over the same kernel functions the
 * CPU tiles run, summed into acc in the CPU's order. */
#ifndef VSD_CONSTELLATION_DEVICE_H
#define VSD_CONSTELLATION_DEVICE_H
#include "src/method/method.h"
#include "src/render/accum.h"
#include "constellation_kernel.h"

/* kc: the host kernel struct (host arrays, kd = &ctx->kd); use_mask: run the mask pass.
 * acc: initialised to the view's size. */
vsd_status vsd_cst_device_render(const vsd_frame_ctx *ctx, const vsd_kconstellation *kc, int use_mask, vsd_accum *acc,
                                 char *err, size_t errlen);

#endif
