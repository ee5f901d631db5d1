# Method crm end to end: against reference on smoke64 frame 24 and on a homogeneous ball under a uniform
# environment, the RBF fit's disk cache counted through method_info, interactive edits in one renderer,
# option errors, an empty grid. 28-47 s on 2 shared cores, hence `slow`.
vsd_add_test(test_crm SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_crm.c LIBS vsd_test_render LABELS integration render crm slow TIMEOUT 600)
