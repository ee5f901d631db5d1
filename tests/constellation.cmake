# The light constellation (core/src/lighting) and the `constellation` method (issue 3).
vsd_add_test(test_lighting SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_lighting.c LIBS vsd_render LABELS unit lighting
             TIMEOUT 120)
vsd_add_test(test_constellation SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_constellation.c LIBS vsd_test_render
             LABELS integration render constellation TIMEOUT 600)
