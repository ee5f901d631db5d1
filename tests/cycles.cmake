# `reference` against Blender Cycles on the same scene (tests/cycles/, docs/cycles-crosscheck.md).
# Renders with real Blender headless, so it runs only where Blender is found (and
# VSD_BLENDER_TESTS is not OFF); VSD_BLENDER_TESTS=ON without Blender is a configure error.
# About 1.5 minutes on a 2-core machine; labelled slow.
if(NOT VSD_BLENDER_TESTS STREQUAL "OFF")
  find_program(BLENDER_EXE blender)
  if(BLENDER_EXE)
    vsd_add_test(test_cycles_crosscheck SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/cycles/test_cycles_crosscheck.c
                 LIBS vsd_lib LABELS blender slow TIMEOUT 2400)
    # The emissive case: fire96 frame 48 with its flame grid (Emit, and emission after one
    # scatter in VolumeDir as Cycles puts it). About 3 minutes on 2 cores.
    add_test(NAME test_cycles_crosscheck_fire COMMAND test_cycles_crosscheck --scene fire --vsd-spp 1024
             --cycles-spp 256 --dir ${VSD_TEST_TMP}/cycles_crosscheck_fire)
    set_tests_properties(test_cycles_crosscheck_fire PROPERTIES LABELS "blender;slow" TIMEOUT 2400
                         SKIP_RETURN_CODE 77)
    # The scene's lights (a point of radius 0.1, a spot with a soft edge, a sun with a
    # 2-degree disc) over a dimmed map: Cycles' light units and spot mask. About 30 s.
    add_test(NAME test_cycles_crosscheck_lights COMMAND test_cycles_crosscheck --scene lights --vsd-spp 1024
             --cycles-spp 256 --dir ${VSD_TEST_TMP}/cycles_crosscheck_lights)
    set_tests_properties(test_cycles_crosscheck_lights PROPERTIES LABELS "blender;slow" TIMEOUT 2400
                         SKIP_RETURN_CODE 77)
    target_compile_definitions(test_cycles_crosscheck PRIVATE
      VSD_BLENDER_EXE="${BLENDER_EXE}"
      VSD_CYCLES_SCRIPT="${CMAKE_CURRENT_SOURCE_DIR}/cycles/cycles_scene.py")
  elseif(VSD_BLENDER_TESTS STREQUAL "ON")
    message(FATAL_ERROR "VSD_BLENDER_TESTS=ON but no blender executable was found (needed by tests/cycles.cmake)")
  endif()
endif()
