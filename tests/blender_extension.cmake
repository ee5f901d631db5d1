# The add-on as a Blender 4.2+ extension (issue 28, finding 4).
#
# `cmake --build build --target vsd_blender_extension_zip` writes build/vsd_blender_extension.zip:
# plugin_blender/blender_manifest.toml and the package's .py files at the zip's root
# (plugin_blender/make_zip.py --extension), for Preferences > Get Extensions > Install from
# Disk... The legacy zip for Blender 3.4-4.1 stays target vsd_blender_zip (blender_addon.cmake).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  add_custom_target(vsd_blender_extension_zip
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/plugin_blender/make_zip.py --extension
            ${CMAKE_BINARY_DIR}/vsd_blender_extension.zip
    BYPRODUCTS ${CMAKE_BINARY_DIR}/vsd_blender_extension.zip
    COMMENT "Packaging the Blender extension: ${CMAKE_BINARY_DIR}/vsd_blender_extension.zip"
    VERBATIM)

  # The manifest's fields and Blender's rules for them, its version = bl_info's, and the
  # layout of both zips, in plain Python (tomllib: Python 3.11+, else exit 77 = skip).
  add_test(NAME blender_addon_manifest
           COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/blender_addon/test_manifest.py)
  set_tests_properties(blender_addon_manifest PROPERTIES LABELS "blender;unit" TIMEOUT 60
                       SKIP_RETURN_CODE 77)
endif()

# Under each bpy wheel (4.2, 4.5, 5.0; tests/common/blender_wheels.cmake): Blender's own
# validator and `extension build` on the zip, Install from Disk into a temporary repository
# (module bl_ext.vsd_test_repo.vsd_blender), F12 through it, and the refusal of a remote
# daemon while Allow Online Access is off. Names: blender42_addon_extension, ...
vsd_add_wheel_addon_tests(extension)
