# `vsd farm` (docs/farm.md): the job-array script, status and errors without a cluster
# (farm_cli.sh), and the whole kill-and-resubmit cycle on a real one-node Slurm cluster
# (farm_slurm.sh; starts one with scripts/slurm-local.sh unless `sinfo` answers already,
# skips where Slurm is not installed).
add_test(NAME farm_cli COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/farm_cli.sh $<TARGET_FILE:vsd>
         ${CMAKE_SOURCE_DIR} ${VSD_SHARED_DATA} ${VSD_TEST_TMP})
set_tests_properties(farm_cli PROPERTIES LABELS "farm;integration" TIMEOUT 120 SKIP_RETURN_CODE 77)
add_test(NAME farm_slurm COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/farm_slurm.sh $<TARGET_FILE:vsd>
         ${CMAKE_SOURCE_DIR} ${VSD_SHARED_DATA} ${VSD_TEST_TMP})
set_tests_properties(farm_slurm PROPERTIES LABELS "farm;integration" TIMEOUT 600 SKIP_RETURN_CODE 77
                     RESOURCE_LOCK slurm)
