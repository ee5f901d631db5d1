# The daemon's isolated loader (issue 16 item 3): the loader API in both modes (linked
# from vsd_daemon, its child being the real `vsd`) and `vsd serve` processes whose loader
# child is made to crash, hang and run out of memory by a test hook.
add_executable(test_daemon_isolation ${CMAKE_CURRENT_SOURCE_DIR}/test_daemon_isolation.c)
target_link_libraries(test_daemon_isolation PRIVATE vsd_testlib vsd_daemon vsd_client vsd_lib Threads::Threads)
set_target_properties(test_daemon_isolation PROPERTIES LINKER_LANGUAGE CXX)
target_compile_options(test_daemon_isolation PRIVATE -Wno-format-truncation)
target_include_directories(test_daemon_isolation PRIVATE ${CMAKE_SOURCE_DIR}/core)
add_test(NAME test_daemon_isolation COMMAND test_daemon_isolation $<TARGET_FILE:vsd>
         WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(test_daemon_isolation PROPERTIES LABELS "integration;service" TIMEOUT 300 SKIP_RETURN_CODE 77)
