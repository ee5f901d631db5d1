# Daemon benchmark (issue 5, "Measure"; results in docs/daemon-bench.md): round-trip overhead
# against in-process rendering, blob upload throughput, camera change on a cached shgrid
# preparation. Starts its own `vsd serve` (the vsd target, or --vsd PATH).
add_executable(vsd_bench_daemon ${CMAKE_SOURCE_DIR}/bench/daemon/bench_daemon.c)
target_link_libraries(vsd_bench_daemon PRIVATE vsd_client vsd_proto vsd_lib)
target_compile_definitions(vsd_bench_daemon PRIVATE VSD_SHARED_DATA="${CMAKE_SOURCE_DIR}/../shared/data"
                           VSD_EXECUTABLE="$<TARGET_FILE:vsd>")
add_dependencies(vsd_bench_daemon vsd)
