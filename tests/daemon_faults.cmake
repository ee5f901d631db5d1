# Load and faults of `vsd serve` (issue 16 item 4): the RSS bound for crm alone (renderers
# counted at what they hold), kill -9 mid-frame, SIGTERM drain, --allow-path, and a short
# soak (8 clients x 40 mixed jobs with cancels and disconnects: no failed job, no leaked
# thread or fd, RSS within the cache budget plus overhead, sampled).
# One ctest entry per check so a failure names its contract. The full soak is
# scripts/soak.py (figures in docs/soak.md).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  foreach(check soak memory kill9 sigterm paths)
    add_test(NAME daemon_faults_${check}
             COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/test_daemon_faults.py ${check}
                     $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/daemon_faults_${check})
    set_tests_properties(daemon_faults_${check} PROPERTIES LABELS "service;integration" TIMEOUT 300
                         SKIP_RETURN_CODE 77)
  endforeach()
  # they measure one daemon's memory: alone, so that ctest -j shares no core with them
  set_tests_properties(daemon_faults_memory daemon_faults_soak PROPERTIES RUN_SERIAL TRUE)
endif()
