# Compensated ray marching (Zhou et al. 2008 §5.2): the 8-bit residual in a perfect spatial hash, exact decoding, sizes, errors.
vsd_add_test(test_crm_hash SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_crm_hash.c LABELS unit crm)
