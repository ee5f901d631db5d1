# Kernels, methods and the render pipeline.
vsd_add_test(test_kernel SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_kernel.c LIBS vsd_render LABELS unit kernel)
vsd_add_test(test_render SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_render.c LIBS vsd_test_render LABELS integration render
             TIMEOUT 1200)
# The method option tables: the one checker, every method's published table round-tripped.
vsd_add_test(test_method_options SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_method_options.c LIBS vsd_lib PkgConfig::CJSON
             LABELS unit render)
# Adaptive view sampling (src/method/adaptive_view.c) through lbl and crm: the image against
# tracing every pixel, anchors exact, a threshold that interpolates everything fails, odd
# film sizes, no adaptive sampling at low resolutions.
vsd_add_test(test_adaptive_view SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_adaptive_view.c LIBS vsd_test_render LABELS integration render)
# Scenes with several volumes (issue 30): overlaps against the single volumes they equal
# (summed density; scatterer + absorber = the mixture's albedo; emission adds), the
# transmittance product of volumes in a row, per-volume frame offsets and caches, errors.
vsd_add_test(test_volumes SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_volumes.c LIBS vsd_test_render
             LABELS integration render TIMEOUT 1500)
# `reference` with a fast method's light as a control variate (issue 33, render.options.cache):
# the closed-form phase mean, the P1 fit of lbl's cones, no bias against plain reference at
# 16384 spp on a smoke, a cloud and a fire, VolumeDir unchanged bit for bit, the errors.
vsd_add_test(test_reference_cache SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_reference_cache.c LIBS vsd_test_render
             LABELS integration render slow TIMEOUT 900)
# The half-resolution volume and the density levels of shgrid's records and constellation's shadow grid.
vsd_add_test(test_density_levels SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_density_levels.c LIBS vsd_render LABELS unit render)
# The CPU pool's wavefront order (device/cpu/cpu_wavefront.h, lbl's Gauss-Seidel lattice):
# dependencies held on several grids and thread counts, the same bits on any thread count.
vsd_add_test(test_cpu_wavefront SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_cpu_wavefront.c LIBS vsd_render LABELS unit render)
