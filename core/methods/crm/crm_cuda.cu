// CUDA entries of `crm` (crm_device.c): the per-view node pass (the paper's volume pass,
// one thread per node) and the view march, n x n strata per pixel, over one volume or several.
#include "device/cuda/cuda_pass.cuh"
#include "crm_kernel.h"
#include "crm_volumes_kernel.h"

VSD_CUDA_ITEM_PASS(vsd_cuda_crm_view_nodes, vsd_kcrm, vsd_crm_view_node)
VSD_CUDA_PIXEL_PASS(vsd_cuda_crm_view, vsd_kcrm, vsd_crm_pass_sample)
VSD_CUDA_PIXEL_PASS(vsd_cuda_crm_volumes_view, vsd_kcrm_volumes, vsd_crm_volumes_sample)
