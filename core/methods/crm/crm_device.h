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

#endif
