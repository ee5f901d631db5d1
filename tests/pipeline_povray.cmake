# POV-Ray interop (docs/povray.md): `vsd export pov` and `vsd composite`.
# The tests that run POV-Ray exit 77 (skipped) when `povray` is not installed.
set(pov_test_libs vsd_pipeline vsd_test_render)
vsd_add_test(test_pov_df3 SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_pov_df3.c LIBS ${pov_test_libs}
             LABELS unit pipeline io TIMEOUT 60)
vsd_add_test(test_pov_composite SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_pov_composite.c LIBS ${pov_test_libs}
             LABELS unit pipeline io TIMEOUT 60)
vsd_add_test(test_pov_camera SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_pov_camera.c LIBS ${pov_test_libs}
             LABELS integration pipeline povray TIMEOUT 120)
# The helper of pipeline_povray.sh: coverage IoU of two alpha channels.
add_executable(test_pov_iou ${CMAKE_CURRENT_SOURCE_DIR}/test_pov_iou.c)
target_link_libraries(test_pov_iou PRIVATE vsd_lib)
set_target_properties(test_pov_iou PROPERTIES LINKER_LANGUAGE CXX)
add_test(NAME pipeline_povray COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/pipeline_povray.sh $<TARGET_FILE:vsd>
         $<TARGET_FILE:test_pov_iou> ${CMAKE_SOURCE_DIR} ${VSD_TEST_TMP})
set_tests_properties(pipeline_povray PROPERTIES LABELS "cli;integration;pipeline;povray" TIMEOUT 120
                     SKIP_RETURN_CODE 77)
