// CUDA entries of `constellation` (Navarro et al. 2009): the validity mask, one thread per
// view sub-sample, and the lighting pass, one thread per pixel (device/device_pass.h).
#include "device/cuda/cuda_pass.cuh"
#include "constellation_kernel.h"

VSD_CUDA_ITEM_PASS(vsd_cuda_constellation_mask, vsd_kconstellation, vsd_cst_mask_item)
VSD_CUDA_PIXEL_PASS(vsd_cuda_constellation_light, vsd_kconstellation, vsd_cst_pass_sample)
