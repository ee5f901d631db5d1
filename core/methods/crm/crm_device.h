/* crm_device.h — crm's view pass as a device pass (device/device_pass.h): the same
 * per-sample function on CPU tiles and CUDA (crm_cuda.cu), and the struct with the nodes
 * (and the fitted D~ + R where view_density reads it) resident on the device (frame arrays
 * keyed by frame_gen, nodes by lighting_gen, so a camera change uploads only the structs). */
#ifndef VSD_CRM_DEVICE_H
#define VSD_CRM_DEVICE_H
#include "src/method/method.h"
#include "device/device_pass.h"
#include "crm_kernel.h"

extern const vsd_device_pass vsd_crm_view_pass;
/* The per-view node pass on the CPU threads into c->view_nodes (host); on the device it runs
 * inside vsd_crm_view_struct. */
vsd_status vsd_crm_view_nodes_cpu(vsd_frame_ctx *ctx, const vsd_kcrm *c);
vsd_status vsd_crm_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err, size_t errlen);

/* Several volumes (crm_parts.h) on the device: d = part i's host struct h with its nodes
 * in the part's own slots and its node pass for this view run there (with part_ctx, the
 * part's context); d's arrays are device memory, for the table the view's struct fn
 * uploads. */
vsd_status vsd_crm_part_device(const vsd_frame_ctx *part_ctx, const vsd_kcrm *h, int i, vsd_kcrm *d, char *err,
                               size_t errlen);
/* The view over several volumes (crm_volumes_kernel.h), and its struct fn, which expects
 * the parts already made device structs by vsd_crm_part_device. */
extern const vsd_device_pass vsd_crm_volumes_view_pass;
vsd_status vsd_crm_volumes_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err,
                                       size_t errlen);

#endif
