# The Blender add-on (issue 6): packaging target and tests in real Blender.
#
# `cmake --build build --target vsd_blender_zip` writes build/vsd_blender.zip, the installable
# add-on (plugin_blender/vsd_blender, protocol client included), with plugin_blender/make_zip.py.
# The tests run Blender headless against a `vsd serve` they start on a temp socket; each
# takes well under a minute on 2 cores. They are registered only when blender is found and
# VSD_BLENDER_TESTS is not OFF (ON without Blender is a configure error, as in cycles.cmake).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  add_custom_target(vsd_blender_zip
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/plugin_blender/make_zip.py ${CMAKE_BINARY_DIR}/vsd_blender.zip
    BYPRODUCTS ${CMAKE_BINARY_DIR}/vsd_blender.zip
    COMMENT "Packaging the Blender add-on: ${CMAKE_BINARY_DIR}/vsd_blender.zip"
    VERBATIM)
endif()

# The pass-name table of the add-on, in plain Python (no Blender needed).
if(Python3_Interpreter_FOUND)
  add_test(NAME blender_addon_passes
           COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_passes.py)
  set_tests_properties(blender_addon_passes PROPERTIES LABELS "blender;unit" TIMEOUT 60)
endif()

if(NOT VSD_BLENDER_TESTS STREQUAL "OFF")
  find_program(BLENDER_EXE blender)
  find_program(XVFB_RUN xvfb-run)
  if(BLENDER_EXE)
    # versions: what differs between Blender versions (findings of issue 28); feedback: the
    # render header's progress, time left and kept done line, warnings (header, viewport)
    # volumes: several volume objects in one scene (issue 30)
    foreach(t render stream options ior lights versions feedback volumes)
      add_test(NAME blender_addon_${t}
               COMMAND ${BLENDER_EXE} --background --factory-startup --python-exit-code 1
                       --python ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_${t}.py --
                       $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/blender_addon_${t})
      # a Python traceback anywhere (add-on or test) fails the test: errors must be reports
      set_tests_properties(blender_addon_${t} PROPERTIES LABELS "blender;integration" TIMEOUT 300
                           FAIL_REGULAR_EXPRESSION "Traceback \\(most recent call last\\)")
    endforeach()
    # The add-on's export rendered by `reference` against Cycles rendering the same Blender
    # scene, with the cross-check's comparison (test_cycles_crosscheck --compare, from
    # tests/cycles.cmake, registered under the same condition; this file is included first,
    # so the target is named, not tested with if(TARGET)). About 4 minutes on the
    # 2-core machine under load; exit 77 (SKIP) if the configured Blender has gone.
    add_test(NAME blender_addon_cycles
             COMMAND sh -c "if [ ! -x \"$0\" ]; then echo \"SKIP: no Blender at $0\"; exit 77; fi; exec \"$0\" \"$@\""
                     ${BLENDER_EXE} --background --factory-startup --python-exit-code 1
                     --python ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_cycles.py --
                     $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/blender_addon_cycles
                     $<TARGET_FILE:test_cycles_crosscheck>)
    set_tests_properties(blender_addon_cycles PROPERTIES LABELS "blender;integration;slow" TIMEOUT 1800
                         FAIL_REGULAR_EXPRESSION "Traceback \\(most recent call last\\)"
                         SKIP_RETURN_CODE 77)
    if(XVFB_RUN)
      # the viewport preview in a real Blender window (software OpenGL under Xvfb)
      add_test(NAME blender_addon_viewport
               COMMAND ${XVFB_RUN} -a -s "-screen 0 1280x800x24"
                       ${BLENDER_EXE} --factory-startup --python-exit-code 1
                       --python ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_viewport.py --
                       $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/blender_addon_viewport)
      set_tests_properties(blender_addon_viewport PROPERTIES LABELS "blender;integration" TIMEOUT 300
                           FAIL_REGULAR_EXPRESSION "Traceback \\(most recent call last\\)"
                           SKIP_RETURN_CODE 77)
    endif()
  elseif(VSD_BLENDER_TESTS STREQUAL "ON")
    message(FATAL_ERROR "VSD_BLENDER_TESTS=ON but no blender executable was found (needed by tests/blender_addon.cmake)")
  endif()
endif()

# The same F12 and add-on tests under the Blenders of PyPI's bpy wheels (4.2 LTS, 4.5 LTS,
# 5.0; tests/common/blender_wheels.cmake finds them), run by tests/blender_addon/blender_wheel.py
# as `blender -b --python` runs them in a binary; plus test_versions (what differs between
# versions: the engine's constructor, colour spaces, pass names against that version's own
# Cycles, lights, cameras, deprecated node flags), which runs in 3.4 too. Names:
# blender42_addon_render, ... The viewport test needs a window and stays on 3.4 (Xvfb).
foreach(t render stream options ior lights versions feedback volumes)
  vsd_add_wheel_addon_tests(${t})
endforeach()
# The add-on's mapping against each wheel's own Cycles (test_cycles.py as blender_addon_cycles
# runs it in 3.4): the voxel centres differ from 5.0 (docs/cycles-crosscheck.md). The program
# test_cycles_crosscheck comes from tests/cycles.cmake, included after this file.
vsd_add_wheel_addon_tests(cycles LABELS blender integration slow wheel TIMEOUT 1800
                          ARGS $<TARGET_FILE:test_cycles_crosscheck>)
