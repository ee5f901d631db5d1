/* device_frame.h — the frame's data on the CUDA device, for methods whose ctx->cuda is set:
 * the scene's kernel data with its arrays resident on the device (uploaded only when the
 * frame or lighting generation they belong to changed), the per-pixel sums of the view
 * pass, and progress between kernel launches. Methods use these so each one only mirrors
 * its own extra arrays. */
#ifndef VSD_DEVICE_FRAME_H
#define VSD_DEVICE_FRAME_H
#include "src/method/method.h"
#include "src/render/accum.h"
#include "device/cuda/cuda_backend.h"

/* The resident-slot key of host array `host` of generation `gen`. */
uint64_t vsd_device_key(uint64_t gen, const void *host);

/* Every resident slot a frame uses goes through these (not vsd_cuda_upload/scratch), which
 * first name ctx's method to the backend for a method slot, as vsd_device_run does for
 * every pass (vsd_cuda_set_method: a renderer that changed method frees the old one's
 * arrays). A NULL host or 0 bytes gives
 * *dev = NULL. */

/* Device copy of host[bytes] in slot, re-uploaded only when gen or host changed. Such a
 * key is only safe for data that is final for its generation: arrays a prepare stage
 * still rewrites in place after uploading them must use vsd_device_copy. */
vsd_status vsd_device_array(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, uint64_t gen, const void *host,
                            size_t bytes, const void **dev, char *err, size_t errlen);
/* Device copy of host[bytes] in slot, copied every time (key 0). */
vsd_status vsd_device_copy(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, const void *host, size_t bytes,
                           const void **dev, char *err, size_t errlen);
/* Device copy of host[bytes] in slot, copied only when the bytes differ from the last
 * copy's (keyed by their hash): small tables of device pointers built per view. */
vsd_status vsd_device_content(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, const void *host, size_t bytes,
                              const void **dev, char *err, size_t errlen);
/* A device buffer of `bytes` in slot for a pass to write (zeroed when zero != 0), key 0:
 * the next vsd_device_array of the slot copies its host array again. */
vsd_status vsd_device_scratch(const vsd_frame_ctx *ctx, vsd_cuda_slot slot, size_t bytes, int zero, void **dev,
                              char *err, size_t errlen);

/* kv (a copy of ctx->kd.density, or .emission when emission != 0, for volume vol) with its
 * bricks replaced by their resident device copies. */
vsd_status vsd_device_volume(const vsd_frame_ctx *ctx, const vsd_volume *vol, vsd_kvolume *kv, int emission,
                             char *err, size_t errlen);

/* dev = kd with every array (volume bricks, environment and its tables, lights) replaced
 * by its resident device copy. */
vsd_status vsd_device_kernel_data(const vsd_frame_ctx *ctx, const vsd_kernel_data *kd, vsd_kernel_data *dev,
                                  char *err, size_t errlen);

/* Zeroed per-pixel sums on the device for a width x height view. */
vsd_status vsd_device_accum(const vsd_frame_ctx *ctx, int width, int height, double **dev, char *err,
                            size_t errlen);
/* The end of a device view pass that returned st: when it finished or was cancelled (the
 * bands done are in the sums, as the CPU's finished tiles are), copies the device sums into
 * acc (initialised to the same size). Returns st, or the copy's failure. */
vsd_status vsd_device_accum_collect(const vsd_frame_ctx *ctx, const double *dev, vsd_accum *acc, vsd_status st,
                                    char *err, size_t errlen);

/* Bytes of the per-pixel sums of a width x height view. */
size_t vsd_device_accum_bytes(int width, int height);

/* The largest kernel struct a method hands a device pass (the backend copies it per launch). */
#define VSD_DEVICE_STRUCT_MAX 4096

/* Runs a method's device pass (device/device_pass.h) on ctx->cuda: m is its kernel struct
 * with device arrays (NULL for a pass reading kd only), kd the host kernel data it reads
 * (its arrays are made resident here), progress [base, base + span) of the pass's stage. */
vsd_status vsd_device_run(const vsd_frame_ctx *ctx, const struct vsd_device_pass *pass, const void *m,
                          const vsd_kernel_data *kd, vsd_pass_args a, int items, void *out, size_t out_bytes,
                          float base, float span, char *err, size_t errlen);

/* Progress of a device stage: ctx's callback and cancel flag, [base, base + span). */
void vsd_device_progress(const vsd_frame_ctx *ctx, const char *stage, float base, float span,
                         vsd_cuda_progress *p);

#endif
