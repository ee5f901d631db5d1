vsd_add_test(test_crm_sweep SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_crm_sweep.c LABELS unit crm)
