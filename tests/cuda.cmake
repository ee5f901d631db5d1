# CUDA backend: CPU/GPU parity, residency and out-of-memory (exits 77 = skip without a GPU).
vsd_add_test(test_cuda SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_cuda.c LIBS vsd_lib LABELS gpu integration
             TIMEOUT 1200)
