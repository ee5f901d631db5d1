# Benchmark of the `constellation` method (issue 3): Table-1 speed-ups, RMSE against
# reference, and the 30-frame smoke64 sequence. Results: docs/methods/constellation.md.
add_executable(vsd_bench_constellation ${CMAKE_SOURCE_DIR}/bench/constellation/bench_constellation.c)
target_link_libraries(vsd_bench_constellation PRIVATE vsd_lib)
target_include_directories(vsd_bench_constellation PRIVATE ${CMAKE_SOURCE_DIR}/core)
target_compile_definitions(vsd_bench_constellation PRIVATE VSD_SHARED_DATA="${CMAKE_SOURCE_DIR}/../shared/data")
set_target_properties(vsd_bench_constellation PROPERTIES LINKER_LANGUAGE CXX)
