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

# The package is complete as it stands in the repository: copying this folder into
# Blender's addons folder installs it, as the zip does (vsd_client.py, the stdlib-only
# protocol client, lives here too and is shared with tests/test_python_client.py).
import bpy

from . import connection, engine, export, ui, vsd_client  # noqa: F401


def register():
    ui.register()
    bpy.utils.register_class(engine.VSDRenderEngine)
    bpy.utils.register_class(export.VSD_OT_export_scene)
    bpy.types.TOPBAR_MT_file_export.append(export.menu_func)
    bpy.app.handlers.frame_change_post.append(engine.frame_changed)


def unregister():
    if engine.frame_changed in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(engine.frame_changed)
    bpy.types.TOPBAR_MT_file_export.remove(export.menu_func)
    bpy.utils.unregister_class(export.VSD_OT_export_scene)
    bpy.utils.unregister_class(engine.VSDRenderEngine)
    ui.unregister()
    connection.close_all()
    connection.stop_daemon()
