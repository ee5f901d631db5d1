vsd_add_test(test_crm_fit SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_crm_fit.c LABELS unit crm)
