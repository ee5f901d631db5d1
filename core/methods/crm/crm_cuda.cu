// CUDA entry of `crm`: the compensated view march, n x n strata per pixel (crm_device.c).
#include "device/cuda/cuda_pass.cuh"
#include "crm_kernel.h"

VSD_CUDA_PIXEL_PASS(vsd_cuda_crm_view, vsd_kcrm, vsd_crm_pass_sample)
