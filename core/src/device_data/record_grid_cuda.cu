// CUDA entry of the record grids' view pass (shgrid, constellation's cached shadows).
#include "device/cuda/cuda_pass.cuh"
#include "kernel/kernel_record_grid.h"

VSD_CUDA_PIXEL_PASS(vsd_cuda_record_grid_view, vsd_krecord_grid, vsd_records_pass_sample)
