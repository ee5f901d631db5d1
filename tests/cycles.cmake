# `reference` against Blender Cycles on the same scene (tests/cycles/, docs/cycles-crosscheck.md).
# Renders with real Blender headless, so it runs only where Blender is found (and
# VSD_BLENDER_TESTS is not OFF); VSD_BLENDER_TESTS=ON without Blender is a configure error.
# About 1.5 minutes on a 2-core machine; labelled slow.
#
# The same cross-check also runs against the Cycles of each bpy wheel that
# tests/common/blender_wheels.cmake finds (4.2 LTS, 4.5 LTS, 5.0; see "Newer Cycles" in the
# doc), on the smoke and the fire scene: test_cycles_crosscheck_blender42,
# test_cycles_crosscheck_fire_blender42, ... (labels blender;slow;wheel). `--blender` is then
# the wheel's python followed by tests/blender_addon/blender_wheel.py, one argument of words
# separated by spaces.
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
  elseif(VSD_BLENDER_WHEEL_VERSIONS)
    # No Blender binary, but bpy wheels: build the program for the wheel tests only (what
    # vsd_add_test does, without registering the 3.4 test).
    add_executable(test_cycles_crosscheck ${CMAKE_CURRENT_SOURCE_DIR}/cycles/test_cycles_crosscheck.c)
    target_link_libraries(test_cycles_crosscheck PRIVATE vsd_testlib vsd_lib)
    target_include_directories(test_cycles_crosscheck PRIVATE ${CMAKE_SOURCE_DIR}/core)
    set_target_properties(test_cycles_crosscheck PROPERTIES LINKER_LANGUAGE CXX)
    target_compile_definitions(test_cycles_crosscheck PRIVATE
      VSD_CYCLES_SCRIPT="${CMAKE_CURRENT_SOURCE_DIR}/cycles/cycles_scene.py")
  endif()

  # Per wheel: smoke and fire with the 3.4 tests' samples, scenes, seeds and bounds. The six
  # took 231 s together on the 2-core VM (4.x 32-65 s each, 5.0 19-26 s; 297 s with the VM
  # shared), see
  # docs/cycles-crosscheck.md, "Newer Cycles". The bounds flag a bias of ~4 % in Combined RGB
  # and ~0.7 % in alpha (smoke), ~1.3 % in a pass's mean; the half-voxel error (alpha ~40x
  # the bound's floor) and 4.x's spot cosine far beyond. The lights scene per wheel runs
  # with --spot-no-cosine: 4.2+ Cycles' spot has no cosine to its axis (scene spot_cosine).
  set(VSD_CYCLES_WHEEL_SMOKE_SPP --vsd-spp 2048 --cycles-spp 512)
  set(VSD_CYCLES_WHEEL_FIRE_SPP --vsd-spp 1024 --cycles-spp 256)
  foreach(v ${VSD_BLENDER_WHEEL_VERSIONS})
    vsd_wheel_blender(wheel_blender ${v})
    vsd_wheel_tag(tag ${v})
    string(REPLACE ";" " " wheel_cmd "${wheel_blender}")
    add_test(NAME test_cycles_crosscheck_blender${tag}
             COMMAND test_cycles_crosscheck --blender "${wheel_cmd}" ${VSD_CYCLES_WHEEL_SMOKE_SPP}
                     --dir ${VSD_TEST_TMP}/cycles_crosscheck_blender${tag})
    add_test(NAME test_cycles_crosscheck_fire_blender${tag}
             COMMAND test_cycles_crosscheck --blender "${wheel_cmd}" --scene fire ${VSD_CYCLES_WHEEL_FIRE_SPP}
                     --dir ${VSD_TEST_TMP}/cycles_crosscheck_fire_blender${tag})
    # the lights scene with the spot as 4.2+ Cycles shapes it (no cosine to the axis)
    add_test(NAME test_cycles_crosscheck_lights_blender${tag}
             COMMAND test_cycles_crosscheck --blender "${wheel_cmd}" --scene lights --spot-no-cosine
                     --vsd-spp 1024 --cycles-spp 256 --dir ${VSD_TEST_TMP}/cycles_crosscheck_lights_blender${tag})
    set_tests_properties(test_cycles_crosscheck_blender${tag} test_cycles_crosscheck_fire_blender${tag}
                         test_cycles_crosscheck_lights_blender${tag}
                         PROPERTIES LABELS "blender;slow;wheel" TIMEOUT 2400 SKIP_RETURN_CODE 77)
    # Three volumes (issue 30): a fire, a smoke overlapping it with another material and
    # frame, a cloud above. Only against 5.0: Cycles 3.4-4.5 add overlapping volumes of
    # different materials about 30 % too brightly (docs/cycles-crosscheck.md, "Several
    # volumes"); 5.0 agrees with vsd. About 60 s on 2 cores.
    if(tag STREQUAL "50")
      add_test(NAME test_cycles_crosscheck_volumes_blender${tag}
               COMMAND test_cycles_crosscheck --blender "${wheel_cmd}" --scene volumes --vsd-spp 1024 --cycles-spp 256
                       --dir ${VSD_TEST_TMP}/cycles_crosscheck_volumes_blender${tag})
      set_tests_properties(test_cycles_crosscheck_volumes_blender${tag}
                           PROPERTIES LABELS "blender;slow;wheel" TIMEOUT 2400 SKIP_RETURN_CODE 77)
    endif()
  endforeach()
endif()
