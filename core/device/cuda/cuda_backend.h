/* cuda_backend.h — the CUDA backend as C code sees it (DESIGN.md §8).
 *
 * One vsd_cuda per renderer: a CUDA stream on device 0 plus *resident slots*, device
 * buffers that keep the frame's data (volume bricks, environment tables, each method's
 * prepared arrays) between renders. A slot is re-uploaded only when the caller's key for
 * it changes, so the daemon's cached renderer re-renders a new camera by uploading nothing
 * but the kernel-data struct that holds the camera.
 *
 * Kernel structs (vsd_kernel_data, vsd_krecord_grid, vsd_kconstellation) are passed as host
 * copies whose array pointers are device pointers (from vsd_cuda_upload/vsd_cuda_scratch);
 * the launchers copy them to the device and fix up the struct-to-struct `kd` pointer.
 * The launched kernels are the same per-pixel / per-record functions the CPU backend
 * runs (core/kernel, core/methods/<name>/<name>_kernel.h), and every sample result is
 * summed with the CPU's accumulation code (kernel/kernel_accum.h), in the CPU's order.
 *
 * Errors come back as vsd_status with CUDA's own message: VSD_ERR_UNSUPPORTED when no
 * device answers (or this build has no CUDA), VSD_ERR_NOMEM when device memory runs out,
 * VSD_ERR_DEVICE for a failed launch. A build without nvcc links cuda_absent.c instead,
 * whose vsd_cuda_open always fails with VSD_ERR_UNSUPPORTED. */
#ifndef VSD_CUDA_BACKEND_H
#define VSD_CUDA_BACKEND_H
#include <stddef.h>
#include <stdint.h>
#include "vsd/status.h"
#include "vsd/render.h"
#include "kernel/kernel_types.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct vsd_cuda vsd_cuda;

/* Resident slots. Frame slots change with the volume frame, lighting slots with the
 * environment or medium, view slots every render (scratch). */
typedef enum vsd_cuda_slot {
    VSD_SLOT_DENSITY_BRICKS, VSD_SLOT_DENSITY_VOXELS, VSD_SLOT_DENSITY_MAX,
    VSD_SLOT_EMISSION_BRICKS, VSD_SLOT_EMISSION_VOXELS, VSD_SLOT_EMISSION_MAX,
    VSD_SLOT_ENV_RGB, VSD_SLOT_ENV_ROWS, VSD_SLOT_ENV_COLS,
    VSD_SLOT_LIGHTS,
    VSD_SLOT_ACCUM,                                   /* view: per-pixel sums (doubles) */
    VSD_SLOT_CST_DM_DENSITY, VSD_SLOT_CST_DM_EMISSION, VSD_SLOT_CST_FIELD_DENSITY, VSD_SLOT_CST_CODE_DENSITY,
    VSD_SLOT_CST_FIELD_EMISSION, VSD_SLOT_CST_CODE_EMISSION, VSD_SLOT_CST_FIRST,
    VSD_SLOT_SH_CELLS, VSD_SLOT_SH_RECORDS, VSD_SLOT_SH_POS, VSD_SLOT_SH_DIRS, VSD_SLOT_SH_BASIS,
    VSD_SLOT_SH_RADIANCE, VSD_SLOT_SH_LIGHT, VSD_SLOT_SH_LIGHTS, VSD_SLOT_SH_LIGHT_TRANS,
    VSD_SLOT_COUNT
} vsd_cuda_slot;

/* 1 when this build contains the CUDA backend (nvcc was found), else 0. */
int vsd_cuda_built(void);

/* Opens device 0 (or $VSD_CUDA_DEVICE) with its own stream. $VSD_CUDA_MAX_MB caps the
 * device memory its slots may hold (a daemon sharing the GPU; tests of out-of-memory). */
vsd_status vsd_cuda_open(vsd_cuda **out, char *err, size_t errlen);
void vsd_cuda_close(vsd_cuda *c);
/* "NVIDIA H100 80GB HBM3 (sm_90, 80 GiB)" */
const char *vsd_cuda_device_name(const vsd_cuda *c);
/* Device bytes held in slots, and host-to-device bytes copied since open (tests check
 * that a camera change copies only the kernel structs). */
size_t vsd_cuda_resident_bytes(const vsd_cuda *c);
uint64_t vsd_cuda_uploaded_bytes(const vsd_cuda *c);

/* The device copy of host[0..bytes) in `slot`: copied only when `key` (or bytes) differs
 * from what the slot holds; key 0 always copies. bytes == 0 gives *dev = NULL. */
vsd_status vsd_cuda_upload(vsd_cuda *c, vsd_cuda_slot slot, uint64_t key, const void *host, size_t bytes,
                           void **dev, char *err, size_t errlen);
/* A device buffer of `bytes` in `slot` for kernels to write (zeroed when zero != 0); the
 * slot's key becomes `key`, so a later upload with the same non-zero key copies nothing. */
vsd_status vsd_cuda_scratch(vsd_cuda *c, vsd_cuda_slot slot, uint64_t key, size_t bytes, int zero,
                            void **dev, char *err, size_t errlen);
vsd_status vsd_cuda_download(vsd_cuda *c, void *host, const void *dev, size_t bytes, char *err, size_t errlen);

/* Progress and cancel between kernel launches (launches go in bands of image rows). */
typedef struct vsd_cuda_progress {
    vsd_progress_fn fn;          /* may be NULL */
    void *user;
    const char *stage;
    float base, span;
    volatile int *cancel;        /* may be NULL */
} vsd_cuda_progress;

/* Launchers. `accum` is a device buffer of width*height*VSD_ACC_N doubles (src/render/
 * accum.h layout) that the kernels add sample results into. */
vsd_status vsd_cuda_reference_round(vsd_cuda *c, const vsd_kernel_data *kd, int s0, int s1, double *accum,
                                    const vsd_cuda_progress *p, char *err, size_t errlen);
vsd_status vsd_cuda_raymarch(vsd_cuda *c, const vsd_kernel_data *kd, int n, double *accum,
                             const vsd_cuda_progress *p, char *err, size_t errlen);

struct vsd_krecord_grid;
struct vsd_kconstellation;
/* shgrid: the record pass (one thread per record, into the device array out: the SH
 * records, or with lights != 0 the transmittance toward each extracted light) and the
 * view pass (n x n stratified rays per pixel). */
vsd_status vsd_cuda_shgrid_records(vsd_cuda *c, const struct vsd_krecord_grid *g, const vsd_kernel_data *kd,
                                   int lights, float *out, const vsd_cuda_progress *p, char *err, size_t errlen);
vsd_status vsd_cuda_shgrid_view(vsd_cuda *c, const struct vsd_krecord_grid *g, const vsd_kernel_data *kd, int n,
                                double *accum, const vsd_cuda_progress *p, char *err, size_t errlen);
/* The distance map of src/render/distance_map.h for the volume kv (device arrays), built
 * on the GPU: skip_host receives the 8*brick_dims cells' leap radii, *occupied the count of
 * occupied cells. */
vsd_status vsd_cuda_distance_map(vsd_cuda *c, const vsd_kvolume *kv, float threshold, uint8_t *skip_host,
                                 long long *occupied, char *err, size_t errlen);
/* constellation: the validity mask (into first[width*height*n^2]) and the lighting pass. */
vsd_status vsd_cuda_constellation_mask(vsd_cuda *c, const struct vsd_kconstellation *kc,
                                       const vsd_kernel_data *kd, int32_t *first, const vsd_cuda_progress *p,
                                       char *err, size_t errlen);
vsd_status vsd_cuda_constellation_light(vsd_cuda *c, const struct vsd_kconstellation *kc,
                                        const vsd_kernel_data *kd, double *accum, const vsd_cuda_progress *p,
                                        char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
