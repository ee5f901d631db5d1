// CUDA entry of `reference`: one progressive round of path-tracing samples per pixel
// (device/device_pass.h; the pass is vsd_reference_pass in reference.c).
#include "device/cuda/cuda_pass.cuh"
#include "reference_kernel.h"

VSD_CUDA_PIXEL_PASS(vsd_cuda_reference_round, vsd_kernel_data, vsd_reference_pass_sample)
