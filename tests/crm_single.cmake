vsd_add_test(test_crm_single SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_crm_single.c LABELS unit crm)
