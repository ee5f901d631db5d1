# `vsd render` end to end (tests/cli_render.sh).
add_test(NAME cli_render COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/cli_render.sh $<TARGET_FILE:vsd>
         ${CMAKE_SOURCE_DIR} ${VSD_TEST_TMP})
set_tests_properties(cli_render PROPERTIES LABELS "cli;integration" TIMEOUT 300)
