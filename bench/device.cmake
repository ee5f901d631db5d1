# GPU benchmark of issue 7 (docs/gpu.md): prepare, view and orbit times on CUDA against the
# CPU backend in the same run.
add_executable(bench_device ${CMAKE_SOURCE_DIR}/bench/device/bench_device.c)
target_link_libraries(bench_device PRIVATE vsd_lib m)
set_target_properties(bench_device PROPERTIES LINKER_LANGUAGE CXX)
target_compile_definitions(bench_device PRIVATE VSD_BENCH_DATA="${CMAKE_SOURCE_DIR}/../shared/data")
target_include_directories(bench_device PRIVATE ${CMAKE_SOURCE_DIR}/bench/common)
