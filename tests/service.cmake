# The daemon, protocol v1 and its clients (issue 5): unit tests of the framing and hashes,
# and end-to-end tests against real `vsd serve` processes (C client, raw frames, CLI,
# Python client).
vsd_add_test(test_protocol SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_protocol.c LIBS vsd_proto LABELS unit io service
             TIMEOUT 60)

add_executable(test_daemon ${CMAKE_CURRENT_SOURCE_DIR}/test_daemon.c)
target_link_libraries(test_daemon PRIVATE vsd_test_render vsd_client Threads::Threads)
set_target_properties(test_daemon PROPERTIES LINKER_LANGUAGE CXX)
target_compile_options(test_daemon PRIVATE -Wno-format-truncation)
target_include_directories(test_daemon PRIVATE ${CMAKE_SOURCE_DIR}/core)
add_test(NAME test_daemon COMMAND test_daemon $<TARGET_FILE:vsd> WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(test_daemon PROPERTIES LABELS "integration;service" TIMEOUT 300 SKIP_RETURN_CODE 77)

# Scenes of several volumes through the daemon and `vsd render --remote` (issue 30): bit for
# bit against the in-process renderer, missing blobs of every volume, per-volume cache hits,
# the voxel limit over a scene's volumes.
add_executable(test_daemon_volumes ${CMAKE_CURRENT_SOURCE_DIR}/test_daemon_volumes.c)
target_link_libraries(test_daemon_volumes PRIVATE vsd_test_render vsd_client Threads::Threads)
set_target_properties(test_daemon_volumes PROPERTIES LINKER_LANGUAGE CXX)
target_compile_options(test_daemon_volumes PRIVATE -Wno-format-truncation)
target_include_directories(test_daemon_volumes PRIVATE ${CMAKE_SOURCE_DIR}/core)
add_test(NAME test_daemon_volumes COMMAND test_daemon_volumes $<TARGET_FILE:vsd>
         WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(test_daemon_volumes PROPERTIES LABELS "integration;service" TIMEOUT 300 SKIP_RETURN_CODE 77)

find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  add_test(NAME test_python_client
           COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/test_python_client.py $<TARGET_FILE:vsd>
                   ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/python_client)
  set_tests_properties(test_python_client PROPERTIES LABELS "integration;service" TIMEOUT 300 SKIP_RETURN_CODE 77)
endif()

# The daemon's lock order (issue 29): the checker of service/daemon/lock_order.h, and a
# daemon run in the test's own process with concurrent clients (renders, cancels, a
# disconnect, a timeout, shutdown) that must take no lock out of order.
add_executable(test_daemon_locks ${CMAKE_CURRENT_SOURCE_DIR}/test_daemon_locks.c)
target_link_libraries(test_daemon_locks PRIVATE vsd_testlib vsd_daemon vsd_client vsd_lib Threads::Threads)
set_target_properties(test_daemon_locks PROPERTIES LINKER_LANGUAGE CXX)
target_compile_options(test_daemon_locks PRIVATE -Wno-format-truncation)
target_include_directories(test_daemon_locks PRIVATE ${CMAKE_SOURCE_DIR}/core)
add_test(NAME test_daemon_locks COMMAND test_daemon_locks $<TARGET_FILE:vsd> WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(test_daemon_locks PROPERTIES LABELS "integration;service" TIMEOUT 300 SKIP_RETURN_CODE 77)
