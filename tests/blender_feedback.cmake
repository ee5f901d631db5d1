# What the add-on tells the artist during and after a render (issue 28, B-D):
# tests/blender_addon/test_feedback.py — the render header's progress and time left for a
# raymarch F12 (raymarch is marked the slow baseline in the method menu), the done line
# Blender keeps after the render (RenderEngine.error_set), the scene mapping's warnings in
# the header, the reports and over the viewport preview. It needs no window, so it runs in
# Blender 3.4 (background) and under each bpy wheel (4.2, 4.5, 5.0;
# tests/common/blender_wheels.cmake), where the preview's timer work is called by hand.
# Registered under the same conditions as tests/blender_addon.cmake's tests.
if(NOT VSD_BLENDER_TESTS STREQUAL "OFF")
  find_program(BLENDER_EXE blender)
  if(BLENDER_EXE)
    add_test(NAME blender_addon_feedback
             COMMAND ${BLENDER_EXE} --background --factory-startup --python-exit-code 1
                     --python ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_feedback.py --
                     $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/blender_addon_feedback)
    set_tests_properties(blender_addon_feedback PROPERTIES LABELS "blender;integration" TIMEOUT 300
                         FAIL_REGULAR_EXPRESSION "Traceback \\(most recent call last\\)")
  endif()
endif()

foreach(v ${VSD_BLENDER_WHEEL_VERSIONS})
  vsd_wheel_blender(wheel_blender ${v})
  vsd_wheel_tag(tag ${v})
  add_test(NAME blender${tag}_addon_feedback
           COMMAND ${wheel_blender} --background --factory-startup --python-exit-code 1
                   --python ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_feedback.py --
                   $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/blender${tag}_addon_feedback)
  set_tests_properties(blender${tag}_addon_feedback PROPERTIES LABELS "blender;integration;wheel" TIMEOUT 300
                       FAIL_REGULAR_EXPRESSION "Traceback \\(most recent call last\\)")
endforeach()
