# Lattice-Boltzmann lighting (Bernabei et al. 2012): the lattice step's energy balance, the
# infinite-medium steady state, the marching pass against Beer-Lambert.
vsd_add_test(test_lbl_lattice SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_lbl_lattice.c LABELS unit lbl)
# Method lbl end to end: against reference on smoke64 frame 24 and on the homogeneous ball,
# with negative controls; the warm-started lighting edit; option errors; an empty grid.
vsd_add_test(test_lbl SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_lbl.c LIBS vsd_test_render LABELS integration render lbl slow TIMEOUT 600)
# Bent rays (medium.ior): the ray equation in a linear index field, Snell's law through a
# ball, n = 1 stepping unbiased, and the path tracer's background seen through a ball.
vsd_add_test(test_refraction SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_refraction.c LIBS vsd_test_render LABELS integration render lbl)
# The scene's lights (sun, point, spot): reference's single scattering against a quadrature
# for each type, lbl against reference, a moved light, the errors.
vsd_add_test(test_lights SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_lights.c LIBS vsd_test_render LABELS integration render lbl)
# lbl's first flight along 98 directions: the homogeneous medium's fluence, energy against
# the box's geometry, births with a direction, the escape at a face against the half-space.
vsd_add_test(test_lbl_first_flight SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_lbl_first_flight.c LABELS unit lbl)
vsd_add_test(test_lbl_sweep SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_lbl_sweep.c LABELS unit lbl)
