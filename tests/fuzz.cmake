# Fuzzing (issue 16; tests/fuzz/README.md). Every harness tests/fuzz/fuzz_<name>.c defines
# LLVMFuzzerTestOneInput and has a seed corpus in tests/fuzz/corpus/<name>/.
#  - Every build replays the corpora as ctest tests (fuzz_replay_<name>, labels io and fuzz),
#    so CI's plain build and its ASan/UBSan build (label io) run each committed input once.
#  - -DVSD_FUZZ=ON (clang, with -DVSD_SANITIZE=ON) builds the libFuzzer executables
#    fuzz_<name>; scripts/fuzz.sh configures that build and runs them.
option(VSD_FUZZ "Build the libFuzzer targets tests/fuzz/fuzz_* (clang, with VSD_SANITIZE=ON)" OFF)

set(VSD_FUZZ_DIR ${CMAKE_CURRENT_SOURCE_DIR}/fuzz)
# name -> the module libraries the harness needs
set(vsd_fuzz_harnesses protocol scene vdb env daemon)
set(vsd_fuzz_libs_protocol vsd_proto PkgConfig::CJSON)
set(vsd_fuzz_libs_scene vsd_scene)
set(vsd_fuzz_libs_vdb vsd_vdbio)
set(vsd_fuzz_libs_env vsd_imageio)
set(vsd_fuzz_libs_daemon vsd_daemon Threads::Threads)

if(VSD_FUZZ)
  if(NOT CMAKE_C_COMPILER_ID MATCHES "Clang" OR NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "VSD_FUZZ=ON needs clang: -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++")
  endif()
  # The library must carry ASan/UBSan everywhere (VSD_SANITIZE adds them to every target, so
  # the vsd executable and the tests still link); coverage instrumentation goes on the
  # modules the harnesses reach, and on nothing else.
  if(NOT VSD_SANITIZE)
    message(FATAL_ERROR "VSD_FUZZ=ON needs -DVSD_SANITIZE=ON too (scripts/fuzz.sh sets both)")
  endif()
  foreach(lib vsd_common vsd_volume vsd_scene vsd_imageio vsd_sh vsd_render vsd_vdbio vsd_proto vsd_daemon)
    get_target_property(lib_type ${lib} TYPE)
    if(NOT lib_type STREQUAL "INTERFACE_LIBRARY")
      target_compile_options(${lib} PRIVATE -fsanitize=fuzzer-no-link)
    endif()
  endforeach()
  add_custom_target(fuzz_all)
endif()

foreach(name ${vsd_fuzz_harnesses})
  set(corpus ${VSD_FUZZ_DIR}/corpus/${name})
  if(VSD_FUZZ)
    add_executable(fuzz_${name} ${VSD_FUZZ_DIR}/fuzz_${name}.c)
    target_compile_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
    target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
    add_dependencies(fuzz_all fuzz_${name})
    # replay = run the corpus once, no mutation
    add_test(NAME fuzz_replay_${name} COMMAND fuzz_${name} -runs=0 ${corpus})
  else()
    add_executable(fuzz_replay_${name} ${VSD_FUZZ_DIR}/replay_main.c ${VSD_FUZZ_DIR}/fuzz_${name}.c)
    add_test(NAME fuzz_replay_${name} COMMAND fuzz_replay_${name} ${corpus})
  endif()
  set(exe $<IF:$<BOOL:${VSD_FUZZ}>,fuzz_${name},fuzz_replay_${name}>)
  if(VSD_FUZZ)
    set(exe fuzz_${name})
  else()
    set(exe fuzz_replay_${name})
  endif()
  target_link_libraries(${exe} PRIVATE ${vsd_fuzz_libs_${name}})
  target_include_directories(${exe} PRIVATE ${CMAKE_SOURCE_DIR}/core ${VSD_FUZZ_DIR})
  set_target_properties(${exe} PROPERTIES LINKER_LANGUAGE CXX)
  set_tests_properties(fuzz_replay_${name} PROPERTIES LABELS "io;fuzz" TIMEOUT 300
                       WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
endforeach()
