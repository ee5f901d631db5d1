// CUDA entry of `shgrid`'s record pass, one thread per record (the paper's per-frame GPU
// pass); its view is the record grid's (src/device_data/record_grid_cuda.cu).
#include "device/cuda/cuda_pass.cuh"
#include "shgrid_kernel.h"

VSD_CUDA_ITEM_PASS(vsd_cuda_shgrid_records, vsd_krecord_grid, vsd_shgrid_record_item)
