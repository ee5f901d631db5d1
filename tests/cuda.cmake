# CUDA backend: CPU/GPU parity, residency and out-of-memory (exits 77 = skip without a GPU).
vsd_add_test(test_cuda SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_cuda.c LIBS vsd_test_render LABELS gpu integration
             TIMEOUT 1200)
# The CUDA backend's library side (uploads, residency keys, struct mirroring, device passes)
# against a host emulation of core/device/cuda/cuda_backend.h: runs everywhere, GPU or not.
vsd_add_test(test_device_residency
             SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_device_residency.c
                     ${CMAKE_CURRENT_SOURCE_DIR}/device_emulation/emulated_cuda.c
             LIBS vsd_test_render LABELS integration render TIMEOUT 1200)
