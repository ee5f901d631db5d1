# Scene file v1: parsing, defaults, validation messages, overrides, camera forms, frame paths.
vsd_add_test(test_scene SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_scene.c LIBS vsd_scene LABELS scene unit)
