# The Blenders of PyPI's `bpy` wheels (4.2 LTS, 4.5 LTS, 5.0), found where
# scripts/install-blender-wheels.sh puts them; included by tests/CMakeLists.txt before the
# test modules, so any of them can run a test under each version.
#
#   VSD_BLENDER_WHEELS            the cache folder (default: $VSD_BLENDER_WHEELS, else
#                                 ~/.cache/vsd/blender-wheels)
#   VSD_BLENDER_WHEELS_REQUIRED   ON: a configure error unless every version in
#                                 VSD_BLENDER_WHEEL_EXPECTED is installed (CI sets it)
# Defines VSD_BLENDER_WHEEL_VERSIONS (e.g. 4.2.23;4.5.15;5.0.1) and, for each version V,
# VSD_BLENDER_WHEEL_PYTHON_<V> (the venv's python). vsd_wheel_blender(OUT V) sets OUT to the
# command line that stands in for `blender` (tests/blender_addon/blender_wheel.py).
if(DEFINED ENV{VSD_BLENDER_WHEELS})
  set(_wheels_default "$ENV{VSD_BLENDER_WHEELS}")
else()
  set(_wheels_default "$ENV{HOME}/.cache/vsd/blender-wheels")
endif()
set(VSD_BLENDER_WHEELS "${_wheels_default}" CACHE PATH "Folder of the bpy wheel venvs (scripts/install-blender-wheels.sh)")
# default from the environment, so CI can require the wheels through scripts/test.sh
if("$ENV{VSD_BLENDER_WHEELS_REQUIRED}" MATCHES "^(1|ON|on|yes|true)$")
  set(_wheels_required_default ON)
else()
  set(_wheels_required_default OFF)
endif()
option(VSD_BLENDER_WHEELS_REQUIRED "Fail configuration when a bpy wheel of VSD_BLENDER_WHEEL_EXPECTED is missing"
       ${_wheels_required_default})
set(VSD_BLENDER_WHEEL_EXPECTED 4.2 4.5 5.0)

set(VSD_BLENDER_WHEEL_VERSIONS "")
if(NOT VSD_BLENDER_TESTS STREQUAL "OFF")
  file(GLOB _wheel_markers "${VSD_BLENDER_WHEELS}/bpy-*/.installed")
  foreach(_marker ${_wheel_markers})
    get_filename_component(_dir "${_marker}" DIRECTORY)
    get_filename_component(_name "${_dir}" NAME)
    string(REGEX REPLACE "^bpy-" "" _v "${_name}")
    if(EXISTS "${_dir}/bin/python")
      list(APPEND VSD_BLENDER_WHEEL_VERSIONS ${_v})
      set(VSD_BLENDER_WHEEL_PYTHON_${_v} "${_dir}/bin/python")
    endif()
  endforeach()
endif()
set(_wheels_wanted ${VSD_BLENDER_WHEEL_EXPECTED})
if(VSD_BLENDER_TESTS STREQUAL "OFF")
  set(_wheels_wanted "")   # no Blender tests at all (e.g. CI's sanitizer build): nothing to require
endif()
foreach(_want ${_wheels_wanted})
  set(_found OFF)
  foreach(_v ${VSD_BLENDER_WHEEL_VERSIONS})
    if(_v MATCHES "^${_want}\\.")
      set(_found ON)
    endif()
  endforeach()
  if(NOT _found)
    if(VSD_BLENDER_WHEELS_REQUIRED)
      message(FATAL_ERROR "VSD_BLENDER_WHEELS_REQUIRED: no bpy ${_want} wheel in ${VSD_BLENDER_WHEELS} "
                          "(run scripts/install-blender-wheels.sh)")
    endif()
    message(STATUS "bpy ${_want} wheel not installed: its add-on tests are not registered "
                   "(scripts/install-blender-wheels.sh installs it)")
  endif()
endforeach()
if(VSD_BLENDER_WHEEL_VERSIONS)
  message(STATUS "Blender add-on tests also run under the bpy wheels: ${VSD_BLENDER_WHEEL_VERSIONS}")
endif()

function(vsd_wheel_blender out version)
  set(${out} ${VSD_BLENDER_WHEEL_PYTHON_${version}} ${CMAKE_SOURCE_DIR}/tests/blender_addon/blender_wheel.py
      PARENT_SCOPE)
endfunction()

# "4.5.15" -> "45": the short tag in test names (blender45_addon_render)
function(vsd_wheel_tag out version)
  string(REGEX MATCH "^([0-9]+)\\.([0-9]+)" _m "${version}")
  set(${out} "${CMAKE_MATCH_1}${CMAKE_MATCH_2}" PARENT_SCOPE)
endfunction()

# vsd_add_wheel_addon_tests(TEST [LABELS l ...] [TIMEOUT s] [ARGS a ...]): for each wheel V,
# test blender<tag>_addon_<TEST> runs tests/blender_addon/test_<TEST>.py under that wheel
# with the add-on tests' arguments (vsd, the shared data, a temp folder) and ARGS; any Python
# traceback in its output fails it (errors must be reports).
function(vsd_add_wheel_addon_tests test)
  cmake_parse_arguments(W "" "TIMEOUT" "LABELS;ARGS" ${ARGN})
  if(NOT W_LABELS)
    set(W_LABELS blender integration wheel)
  endif()
  if(NOT W_TIMEOUT)
    set(W_TIMEOUT 300)
  endif()
  foreach(v ${VSD_BLENDER_WHEEL_VERSIONS})
    vsd_wheel_blender(wheel_blender ${v})
    vsd_wheel_tag(tag ${v})
    add_test(NAME blender${tag}_addon_${test}
             COMMAND ${wheel_blender} --background --factory-startup --python-exit-code 1
                     --python ${CMAKE_SOURCE_DIR}/tests/blender_addon/test_${test}.py --
                     $<TARGET_FILE:vsd> ${VSD_SHARED_DATA} ${VSD_TEST_TMP}/blender${tag}_addon_${test} ${W_ARGS})
    set_tests_properties(blender${tag}_addon_${test} PROPERTIES LABELS "${W_LABELS}" TIMEOUT ${W_TIMEOUT}
                         FAIL_REGULAR_EXPRESSION "Traceback \\(most recent call last\\)")
  endforeach()
endfunction()
