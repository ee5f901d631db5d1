# bench_tte: time to error per method and scene (issue 12), and bench/tte/plot_tte.py's CSV.
add_executable(bench_tte ${CMAKE_SOURCE_DIR}/bench/tte/bench_tte.c)
target_link_libraries(bench_tte PRIVATE vsd_lib m)
set_target_properties(bench_tte PROPERTIES LINKER_LANGUAGE CXX)
target_include_directories(bench_tte PRIVATE ${CMAKE_SOURCE_DIR}/bench/common)
target_compile_definitions(bench_tte PRIVATE VSD_BENCH_DATA="${CMAKE_SOURCE_DIR}/../shared/data"
                                             VSD_BENCH_CACHE="${CMAKE_BINARY_DIR}/bench-cache")

# bench_edits: one kind of interactive edit on a kept renderer, each stage's seconds (issue 32).
add_executable(bench_edits ${CMAKE_SOURCE_DIR}/bench/tte/bench_edits.c)
target_link_libraries(bench_edits PRIVATE vsd_lib m)
set_target_properties(bench_edits PROPERTIES LINKER_LANGUAGE CXX)
target_include_directories(bench_edits PRIVATE ${CMAKE_SOURCE_DIR}/bench/common)
