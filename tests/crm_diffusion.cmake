vsd_add_test(test_crm_diffusion SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_crm_diffusion.c LABELS unit crm)
