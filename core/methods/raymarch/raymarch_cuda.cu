// CUDA entry of `raymarch`: its n x n stratified view rays per pixel (device/device_pass.h).
#include "device/cuda/cuda_pass.cuh"
#include "raymarch_kernel.h"

VSD_CUDA_PIXEL_PASS(vsd_cuda_raymarch_view, vsd_kernel_data, vsd_raymarch_pass_sample)
