# File > Export > vsd scene (.json): the Blender scene as a scene file v1 for `vsd render`
# and render farms (docs/architecture.md §4). The volume is written as its #### sequence pattern and
# the frame range as the file frames Blender shows for the scene's range.
import json
import os
import shutil

import bpy
from bpy.props import BoolProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from . import mapping


def _animated(ob):
    ad = ob.animation_data if ob is not None else None
    return bool(ad and (ad.action or ad.drivers))


def output_pattern(scene):
    """Blender's output path -> a vsd output.exr pattern (absolute)."""
    fp = scene.render.filepath or "//render/"
    path = bpy.path.abspath(fp)
    d, name = os.path.split(path)
    if not name:
        name = "frame_"
    stem, ext = os.path.splitext(name)
    if ext.lower() in (".exr", ".png", ".jpg", ".tif", ".tiff"):
        name = stem
    if "#" not in name:
        name += "####"
    if not name.endswith(".exr"):
        name += ".exr"
    return os.path.join(d, name)


def export_scene(context, filepath, relative=True, frame_range=True):
    """Write the scene file; returns (path, warnings)."""
    scene = context.scene
    depsgraph = context.evaluated_depsgraph_get()
    m = mapping.build_scene(depsgraph, active=context.active_object)
    sc = m.scene
    out_dir = os.path.dirname(os.path.abspath(filepath))
    os.makedirs(out_dir, exist_ok=True)

    def rel(p):
        if not relative:
            return p
        try:
            return os.path.relpath(p, out_dir)
        except ValueError:  # another drive
            return p

    ob = m.volume_object
    vol = ob.data.original
    start, end = scene.frame_start, scene.frame_end
    if not frame_range:
        start = end = scene.frame_current
    if vol.is_sequence and "#" in m.volume_pattern:
        files = [mapping.sequence_frame(vol, f) for f in range(start, end + 1)]
        if None in files:
            m.warn("the volume sequence shows no file for part of the frame range %d-%d (Clip "
                   "mode); exported frames %d-%d only" % (start, end, start, end))
            files = [f for f in files if f is not None]
        contiguous = files and all(files[i + 1] == files[i] + 1 for i in range(len(files) - 1))
        if contiguous:
            fstart, fend = files[0], files[-1]
        else:
            cur = mapping.sequence_frame(vol, scene.frame_current) or files[0]
            fstart = fend = cur
            m.warn("the volume sequence does not play frame by frame over %d-%d (repeat, "
                   "ping-pong or extend): exported file frame %d only" % (start, end, cur))
        if (fstart, fend) != (start, end) and contiguous:
            m.warn("scene frames %d-%d show volume files %d-%d: the scene file numbers frames "
                   "by file (%d-%d)" % (start, end, fstart, fend, fstart, fend))
        sc["volume"]["file"] = rel(m.volume_pattern)
        sc["frames"] = {"start": int(fstart), "end": int(fend)}
    else:
        sc["volume"]["file"] = rel(m.volume_path)
        sc["frames"] = {"start": int(start), "end": int(end)}
    if m.env_path:
        env = m.env_path
        if os.path.basename(env).startswith("vsd_env_"):  # a packed/generated image
            dst = os.path.splitext(os.path.abspath(filepath))[0] + "_env.exr"
            shutil.copyfile(env, dst)
            env = dst
        sc["environment"]["file"] = rel(env)
    if _animated(scene.camera):
        m.warn("the camera is animated: the scene file holds its frame-%d position" % scene.frame_current)
    if _animated(ob.original):
        m.warn("volume object '%s' is animated: the scene file holds its frame-%d matrix"
               % (ob.name, scene.frame_current))
    sc["output"]["exr"] = rel(output_pattern(scene))
    with open(filepath, "w") as f:
        json.dump(sc, f, indent=1)
        f.write("\n")
    return filepath, m.warnings


class VSD_OT_export_scene(bpy.types.Operator, ExportHelper):
    """Write the scene as a vsd scene file (version 1) for `vsd render` and render farms"""
    bl_idname = "export_scene.vsd"
    bl_label = "Export vsd Scene"
    bl_options = {"PRESET"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})
    relative_paths: BoolProperty(name="Relative Paths", default=True,
                                 description="Write file paths relative to the scene file")
    frame_range: BoolProperty(name="Frame Range", default=True,
                              description="Export the scene's frame range (else the current frame)")

    def execute(self, context):
        try:
            path, warnings = export_scene(context, self.filepath, self.relative_paths, self.frame_range)
        except mapping.MappingError as e:
            self.report({"ERROR"}, "vsd export: %s" % e)
            return {"CANCELLED"}
        except (OSError, ValueError) as e:
            self.report({"ERROR"}, "vsd export: %s" % e)
            return {"CANCELLED"}
        for w in warnings:
            self.report({"WARNING"}, "vsd export: " + w)
        self.report({"INFO"}, "vsd scene written: %s" % path)
        return {"FINISHED"}


def menu_func(self, context):
    self.layout.operator(VSD_OT_export_scene.bl_idname, text="vsd scene (.json)")
