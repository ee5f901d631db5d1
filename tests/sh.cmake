# Spherical harmonics (vsd_sh): analytic projections, rotation, convolution, triple product, exp*.
vsd_add_test(test_sh SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_sh.c LIBS vsd_sh vsd_imageio LABELS unit sh)
