// CUDA entries of the record grids' view passes (shgrid, constellation's cached shadows, lbl):
// one grid, and one grid per volume of a scene of several.
#include "device/cuda/cuda_pass.cuh"
#include "kernel/kernel_record_grid.h"
#include "kernel/kernel_record_grids.h"

VSD_CUDA_PIXEL_PASS(vsd_cuda_record_grid_view, vsd_krecord_grid, vsd_records_pass_sample)
VSD_CUDA_PIXEL_PASS(vsd_cuda_record_grids_view, vsd_krecord_grids, vsd_records_volumes_sample)
