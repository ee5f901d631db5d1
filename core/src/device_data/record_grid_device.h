/* record_grid_device.h — a record grid (kernel/kernel_record_grid.h) on the CUDA device of
 * ctx. Every array is resident and keyed by ctx->lighting_gen (a new frame always brings a
 * new lighting generation too), so a new camera uploads nothing but the structs. Used by
 * shgrid (its record pass and view) and constellation's cached shadows (view). */
#ifndef VSD_RECORD_GRID_DEVICE_H
#define VSD_RECORD_GRID_DEVICE_H
#include "src/method/method.h"
#include "kernel/kernel_record_grid.h"
#include "device/cuda/cuda_backend.h"

/* d = g with its arrays on the device, in the grid's own resident slots (method slots of
 * record_grid_device.c: the method that runs a record grid owns them); with_records = 0
 * for a record pass, which writes the records (so they are not uploaded) and reads the
 * positions and directions. */
vsd_status vsd_record_grid_device(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int with_records,
                                  vsd_krecord_grid *d, char *err, size_t errlen);

/* The device buffer of `bytes` a record pass writes: the slot of the grid's records
 * (lights = 0) or of its transmittances toward the lights (lights = 1), which the view
 * later uploads into again (the scratch's key 0 never matches). */
vsd_status vsd_record_grid_output(const vsd_frame_ctx *ctx, int lights, size_t bytes, void **dev, char *err,
                                  size_t errlen);

/* The device arrays a pass over grid m reads (view != 0: the view pass; lights: a record
 * pass toward the lights), for the device pass descriptors (device/device_pass.h). */
void vsd_record_grid_arrays(const vsd_krecord_grid *m, int view, int lights, vsd_pass_array_visit visit, void *user);

/* The view pass: n x n strata per pixel (record_grid_cuda.cu on the GPU), and the
 * vsd_device_struct_fn that readies a host grid for it. */
extern const vsd_device_pass vsd_record_grid_view_pass;
vsd_status vsd_record_grid_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err,
                                       size_t errlen);

/* The view over several volumes (kernel_record_grids.h): every grid in its own slots, and
 * their table; the vsd_device_struct_fn of vsd_record_grids_view_pass. */
extern const vsd_device_pass vsd_record_grids_view_pass;
vsd_status vsd_record_grids_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err,
                                        size_t errlen);

#endif
