# Method shgrid: closed-form thin box, reference cross-check on two data sets, convergence, cache.
vsd_add_test(test_shgrid SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_shgrid.c LIBS vsd_test_render LABELS integration render shgrid
             TIMEOUT 600)
