# vsd_blender — the vsd render engine for Blender (docs/blender-addon.md).
#
# Streams the scene's VDB frame and environment map to a vsd daemon (`vsd serve`), with the
# camera and the Principled Volume mapped to a vsd scene file, and loads the multilayer EXR
# it returns as render passes (Combined, VolumeDir, VolumeInd, Emit, Transmittance, Depth).
bl_info = {
    "name": "vsd",
    "author": "vsd project",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render Properties > Render Engine > vsd; File > Export > vsd scene (.json)",
    "description": "Render OpenVDB volumes lit by HDR environments with the vsd daemon",
    "category": "Render",
}

import importlib.util
import os
import sys

# vsd_client.py lives beside the package in the repository (plugin_blender/vsd_client.py)
# and inside it in the zip; either way it is this package's `vsd_client` submodule.
try:
    from . import vsd_client  # noqa: F401  (the zip)
except ImportError:
    _spec = importlib.util.spec_from_file_location(
        __name__ + ".vsd_client", os.path.join(os.path.dirname(os.path.dirname(__file__)), "vsd_client.py"))
    vsd_client = importlib.util.module_from_spec(_spec)
    sys.modules[__name__ + ".vsd_client"] = vsd_client
    _spec.loader.exec_module(vsd_client)

import bpy  # noqa: E402

from . import connection, engine, export, ui  # noqa: E402


def register():
    ui.register()
    bpy.utils.register_class(engine.VSDRenderEngine)
    bpy.utils.register_class(export.VSD_OT_export_scene)
    bpy.types.TOPBAR_MT_file_export.append(export.menu_func)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(export.menu_func)
    bpy.utils.unregister_class(export.VSD_OT_export_scene)
    bpy.utils.unregister_class(engine.VSDRenderEngine)
    ui.unregister()
    connection.close_all()
    connection.stop_daemon()
