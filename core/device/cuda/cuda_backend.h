/* cuda_backend.h — the CUDA backend as C code sees it (docs/architecture.md §8).
 *
 * One vsd_cuda per renderer: a CUDA stream on device 0 plus *resident slots*, device
 * buffers that keep the frame's data (volume bricks, environment tables, each method's
 * prepared arrays) between renders. A slot is re-uploaded only when the caller's key for
 * it changes, so the daemon's cached renderer re-renders a new camera by uploading nothing
 * but the kernel-data struct that holds the camera.
 *
 * The backend knows no method: a method describes each of its passes with a
 * vsd_device_pass (device/device_pass.h) and hands vsd_cuda_run_pass its kernel struct as a
 * host copy whose array pointers are device pointers (from vsd_cuda_upload/scratch); the
 * backend copies it to the device, fixes up its `kd` pointer and launches the method's
 * entry (core/methods/<name>/<name>_cuda.cu) over bands. The launched kernels are the same
 * per-pixel / per-record functions the CPU backend runs, and every sample result is summed
 * with the CPU's accumulation code (kernel/kernel_accum.h), in the CPU's order.
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
#include "device/device_pass.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct vsd_cuda vsd_cuda;

/* Resident slots. A slot is a static descriptor declared next to the code that uses it,
 * and identified by its address: the backend keeps a growable table from descriptors to
 * device buffers, allocated on first use, so adding an array is one declaration and two
 * arrays can never share a slot by a numbering mistake (an overlap used to be silent).
 *
 *     VSD_DEVICE_SLOT(crm_view_nodes, "crm view nodes");
 *     st = vsd_device_scratch(ctx, crm_view_nodes, bytes, 0, &dev, err, errlen);
 *
 * The name is what errors say ("allocating 12.0 MiB of device memory for crm view nodes:
 * out of memory", and a $VSD_CUDA_MAX_MB refusal lists what each slot holds). Give every
 * slot a name of its own: the emulated backend reports two of one name, and distinct
 * contents also keep a linker that folds identical constants from merging two slots.
 * Frame slots change with the volume frame, lighting slots with the environment or medium,
 * view slots every render (scratch): that is the caller's key, not the slot's business.
 *
 * Scene slots (VSD_DEVICE_SCENE_SLOT: the volume, environment, lights, the view's sums)
 * hold what every method reads. Method slots (VSD_DEVICE_SLOT) hold the arrays of the
 * method the renderer runs: a renderer runs one method at a time, so when it names another
 * (vsd_cuda_set_method, which src/device_data/device_frame.c calls before each method-slot
 * access and each device pass) the buffers of all method slots are freed, and a renderer that changed method
 * holds the new method's arrays only, as when methods numbered their slots alike and
 * reused each other's buffers. */
typedef enum vsd_cuda_slot_kind { VSD_CUDA_SCENE_SLOT, VSD_CUDA_METHOD_SLOT } vsd_cuda_slot_kind;
typedef struct vsd_cuda_slot_desc {
    const char *name;
    vsd_cuda_slot_kind kind;
} vsd_cuda_slot_desc;
typedef const vsd_cuda_slot_desc *vsd_cuda_slot;

/* A descriptor object `id` (an array of one, so that `id` is the slot's address). Static
 * in the file that uses it; a slot shared by files defines it once with
 * VSD_DEVICE_SLOT_OBJECT and declares it `extern const vsd_cuda_slot_desc id[1];`. */
#define VSD_DEVICE_SLOT_OBJECT(id, kind, name) const vsd_cuda_slot_desc id[1] = {{name, kind}}
#define VSD_DEVICE_SLOT(id, name) static VSD_DEVICE_SLOT_OBJECT(id, VSD_CUDA_METHOD_SLOT, name)
#define VSD_DEVICE_SCENE_SLOT(id, name) static VSD_DEVICE_SLOT_OBJECT(id, VSD_CUDA_SCENE_SLOT, name)

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
/* Host wall seconds since open inside device passes (launches to the end of their last
 * band: the kernels) and inside downloads (device to host copies), for the figures of a
 * render (vsd_render_stats.device_pass_seconds, device_download_seconds). */
void vsd_cuda_seconds(const vsd_cuda *c, double *passes, double *downloads);

/* The method whose slots c holds (NULL or "" = none named yet): naming a different one
 * frees every VSD_CUDA_METHOD_SLOT slot's buffer (a renderer changed method). */
void vsd_cuda_set_method(vsd_cuda *c, const char *method);

/* The device copy of host[0..bytes) in `slot` (a buffer allocated on the slot's first use,
 * grown when too small): copied only when `key` (or bytes) differs from what the slot
 * holds; key 0 always copies. bytes == 0 gives *dev = NULL. */
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

/* Runs `pass` (device/device_pass.h) over kd's image rows (pixel passes; out is the
 * device sums, width*height*VSD_ACC_N doubles, src/render/accum.h layout) or over
 * `items` items (item passes), in bands with progress and cancel between launches. m is
 * the method's kernel struct (pass->struct_bytes, device arrays inside; NULL when the pass
 * reads kd only); its kd member is pointed at the device copy of kd. out_bytes is what
 * the pass may write (the emulation checks it). */
struct vsd_device_pass;
vsd_status vsd_cuda_run_pass(vsd_cuda *c, const struct vsd_device_pass *pass, const void *m,
                             const vsd_kernel_data *kd, vsd_pass_args a, int items, void *out, size_t out_bytes,
                             const vsd_cuda_progress *p, char *err, size_t errlen);

/* The distance map of src/grids/distance_map.h for the volume kv (device arrays), built
 * on the GPU: skip_host receives the 8*brick_dims cells' leap radii, *occupied the count of
 * occupied cells. */
vsd_status vsd_cuda_distance_map(vsd_cuda *c, const vsd_kvolume *kv, float threshold, uint8_t *skip_host,
                                 long long *occupied, char *err, size_t errlen);
#ifdef __cplusplus
}
#endif
#endif
