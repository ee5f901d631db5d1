# Method shgrid benchmark (docs/methods/shgrid.md): Table 1 axes, cached-view speed against
# raymarch, and the smoke64 sequence.
add_executable(bench_shgrid ${CMAKE_SOURCE_DIR}/bench/shgrid/bench_shgrid.c)
target_link_libraries(bench_shgrid PRIVATE vsd_lib)
target_compile_definitions(bench_shgrid PRIVATE VSD_SHARED_DATA="${CMAKE_SOURCE_DIR}/../shared/data")
