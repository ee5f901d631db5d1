// CUDA entries of `crm` (crm_device.c): the per-view node pass (the paper's volume pass,
// one thread per node) and the compensated view march, n x n strata per pixel.
#include "device/cuda/cuda_pass.cuh"
#include "crm_kernel.h"

VSD_CUDA_ITEM_PASS(vsd_cuda_crm_view_nodes, vsd_kcrm, vsd_crm_view_node)
VSD_CUDA_PIXEL_PASS(vsd_cuda_crm_view, vsd_kcrm, vsd_crm_pass_sample)
