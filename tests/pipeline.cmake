# The offline pipeline around `vsd render` (docs/pipeline.md): POV-Ray INI files and
# switches, --continue after a kill, progress lines (tests/pipeline_render.sh).
add_test(NAME pipeline_render COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/pipeline_render.sh $<TARGET_FILE:vsd>
         ${CMAKE_SOURCE_DIR} ${VSD_TEST_TMP})
set_tests_properties(pipeline_render PROPERTIES LABELS "cli;integration" TIMEOUT 300)
