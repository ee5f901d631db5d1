# Every option is exercised (issue 29 item 7): every method of the registry, every BOOL and
# CHOICE value not the default, rendered on a 24x16 smoke64 against the image without it
# (with the prerequisites its "applies_when" rule needs): the image must change, or the value
# be declared a no-op for that scene with its reason (and then give the same image). Every
# rule refused where it does not hold. About 15 s on 2 cores.
vsd_add_test(test_option_coverage SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_option_coverage.c
             LIBS vsd_test_render PkgConfig::CJSON LABELS integration render TIMEOUT 300)
