# `vsd render` end to end (tests/cli_render.sh).
add_test(NAME cli_render COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/cli_render.sh $<TARGET_FILE:vsd>
         ${CMAKE_SOURCE_DIR} ${VSD_TEST_TMP})
set_tests_properties(cli_render PROPERTIES LABELS "cli;integration" TIMEOUT 300)

# The light `vsd` front and vsd-core behind it (tests/cli_front.sh).
add_test(NAME cli_front COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/cli_front.sh $<TARGET_FILE:vsd>
         $<TARGET_FILE:vsd-core> ${CMAKE_SOURCE_DIR} ${VSD_TEST_TMP})
set_tests_properties(cli_front PROPERTIES LABELS "cli;integration" TIMEOUT 300)
