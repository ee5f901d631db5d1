# Tests of the vsd_imageio module (core/src/image, core/src/env): multilayer EXR, preview
# PNG through OpenColorIO, environment maps. Included by tests/CMakeLists.txt.
vsd_add_test(test_image SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_image.c LIBS vsd_imageio LABELS io unit)
vsd_add_test(test_env SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_env.c LIBS vsd_imageio LABELS io data)

# Proof that Blender itself reads our multilayer EXR as render passes: test_image writes a
# known sample (--write-sample), Blender loads it and checks pass names and pixel values.
if(NOT VSD_BLENDER_TESTS STREQUAL "OFF")
  find_program(BLENDER_EXE blender)
  if(BLENDER_EXE)
    add_test(NAME blender_exr_passes
             COMMAND ${BLENDER_EXE} --background --factory-startup --python-exit-code 1
                     --python ${CMAKE_CURRENT_SOURCE_DIR}/blender_exr_passes.py
                     -- $<TARGET_FILE:test_image> ${VSD_TEST_TMP}/blender_passes.exr)
    set_tests_properties(blender_exr_passes PROPERTIES LABELS "io;blender" TIMEOUT 300)
  elseif(VSD_BLENDER_TESTS STREQUAL "ON")
    message(FATAL_ERROR "VSD_BLENDER_TESTS=ON but no blender executable was found")
  endif()
endif()
