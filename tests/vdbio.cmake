# Tests of the volume module (core/src/volume) and the OpenVDB loader (vdbio), and `vsd info`.
vsd_add_test(test_volume SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_volume.c LIBS vsd_volume LABELS io unit)
vsd_add_test(test_vdbio SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_vdbio.c LIBS vsd_vdbio LABELS io data)

# `vsd info` lists the grids of a real file ...
add_test(NAME cli_info COMMAND vsd info ${VSD_SHARED_DATA}/smoke64/fluid_data_0001.vdb)
set_tests_properties(cli_info PROPERTIES LABELS "io;cli"
  PASS_REGULAR_EXPRESSION "grid 0: velocity.*vec3s.*grid 1: density.*type +float.*active voxels +3456.*grid 4: flame.*active voxels +0")
# ... names the file and the problem on stderr for a missing one ...
add_test(NAME cli_info_missing COMMAND vsd info ${VSD_TEST_TMP}/no_such_file.vdb)
set_tests_properties(cli_info_missing PROPERTIES LABELS "io;cli"
  PASS_REGULAR_EXPRESSION "no_such_file\\.vdb: no such file")
# ... and exits with 3 (bad input) for it, 2 for a bad command line.
add_test(NAME cli_info_missing_status
  COMMAND sh -c "\"$0\" info \"$1\"; test $? -eq 3" $<TARGET_FILE:vsd> ${VSD_TEST_TMP}/no_such_file.vdb)
set_tests_properties(cli_info_missing_status PROPERTIES LABELS "io;cli")
add_test(NAME cli_info_usage_status COMMAND sh -c "\"$0\" info; test $? -eq 2" $<TARGET_FILE:vsd>)
set_tests_properties(cli_info_usage_status PROPERTIES LABELS "io;cli")

# Byte-mutated copies of two shared VDBs rendered at 16x9, 1 spp: an image or a named error
# for each, none slower than 5 s (issue 16's mutation experiment, seeded and committed).
vsd_add_test(test_hostile_vdb SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test_hostile_vdb.c LABELS data slow)
