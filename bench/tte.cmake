# bench_tte: time to error per method and scene (issue 12), and bench/tte/plot_tte.py's CSV.
add_executable(bench_tte ${CMAKE_SOURCE_DIR}/bench/tte/bench_tte.c)
target_link_libraries(bench_tte PRIVATE vsd_lib m)
set_target_properties(bench_tte PROPERTIES LINKER_LANGUAGE CXX)
# bench_cycles.h runs Blender through tests/cycles/run_logged.h (--cycles-spp)
target_include_directories(bench_tte PRIVATE ${CMAKE_SOURCE_DIR}/bench/common ${CMAKE_SOURCE_DIR}/tests/cycles)
find_program(VSD_BENCH_BLENDER blender)
if(NOT VSD_BENCH_BLENDER)
  set(VSD_BENCH_BLENDER "blender")
endif()
target_compile_definitions(bench_tte PRIVATE VSD_BENCH_DATA="${CMAKE_SOURCE_DIR}/../shared/data"
                                             VSD_BENCH_CACHE="${CMAKE_BINARY_DIR}/bench-cache"
                                             VSD_BENCH_BLENDER="${VSD_BENCH_BLENDER}"
                                             VSD_BENCH_CYCLES_SCRIPT="${CMAKE_SOURCE_DIR}/tests/cycles/cycles_scene.py")

# bench_edits: one kind of interactive edit on a kept renderer, each stage's seconds (issue 32).
add_executable(bench_edits ${CMAKE_SOURCE_DIR}/bench/tte/bench_edits.c)
target_link_libraries(bench_edits PRIVATE vsd_lib m)
set_target_properties(bench_edits PROPERTIES LINKER_LANGUAGE CXX)
target_include_directories(bench_edits PRIVATE ${CMAKE_SOURCE_DIR}/bench/common)
