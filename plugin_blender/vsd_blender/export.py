# File > Export > vsd scene (.json): the Blender scene as a scene file v1 for `vsd render`
# and render farms (docs/architecture.md §4). Each volume is written as its #### sequence pattern
# with the frame_offset that gives the file Blender shows at each scene frame; the frames are
# the scene's.
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


def _sequence_frames(volumes, start, end):
    """{index: [file frame shown at each scene frame start..end (None: none)]} of the
    volumes that are #### sequences."""
    out = {}
    for i, v in enumerate(volumes):
        vol = v.object.data.original
        if vol.is_sequence and vol.packed_file is None and "#" in v.pattern:
            out[i] = [mapping.sequence_frame(vol, f) for f in range(start, end + 1)]
    return out


def export_frames(m, start, end, current):
    """The scene frames to export and each sequence's frame_offset ({volume index: offset}):
    file #### = scene frame + frame_offset, the scene file's rule (docs/scene-file.md), so
    the EXRs are numbered by scene frame as Blender numbers its own. A range where some
    volume shows no file (Clip mode) shrinks to the frames where all show one; a volume that
    does not play frame by frame (repeat, ping-pong, extend) limits the export to the
    current frame. Each is a warning."""
    seqs = _sequence_frames(m.volumes, start, end)
    shown = [f for f in range(start, end + 1) if all(files[f - start] is not None for files in seqs.values())]
    if len(shown) < end - start + 1:
        names = ", ".join("'%s'" % m.volumes[i].object.name for i, files in seqs.items() if None in files)
        if shown:
            m.warn("volume %s shows no file for part of the frame range %d-%d (Clip mode): exported frames "
                   "%d-%d only" % (names, start, end, shown[0], shown[-1]))
            seqs = {i: files[shown[0] - start:shown[-1] - start + 1] for i, files in seqs.items()}
            start, end = shown[0], shown[-1]
        else:
            m.warn("the volumes %s show no file together anywhere in the frame range %d-%d (Clip mode): "
                   "exported frame %d only" % (names, start, end, current))
            start = end = current
            seqs = _sequence_frames(m.volumes, current, current)
    stepped = [i for i, files in seqs.items()
               if not all(files[k + 1] == files[k] + 1 for k in range(len(files) - 1))]
    if stepped:
        for i in stepped:
            m.warn("volume '%s': its sequence does not play frame by frame over %d-%d (repeat, ping-pong or "
                   "extend): exported frame %d only" % (m.volumes[i].object.name, start, end, current))
        start = end = current
        seqs = _sequence_frames(m.volumes, current, current)
    offsets = {i: files[0] - start for i, files in seqs.items()}
    return start, end, offsets


def export_scene(context, filepath, relative=True, frame_range=True):
    """Write the scene file; returns (path, warnings)."""
    scene = context.scene
    depsgraph = context.evaluated_depsgraph_get()
    m = mapping.build_scene(depsgraph, export=True)
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

    start, end = scene.frame_start, scene.frame_end
    if not frame_range:
        start = end = scene.frame_current
    start, end, offsets = export_frames(m, start, end, scene.frame_current)
    sc["frames"] = {"start": int(start), "end": int(end)}
    for i, v in enumerate(m.volumes):
        entry = sc["volumes"][i]
        if i in offsets:
            entry["file"] = rel(v.pattern)
            if offsets[i]:
                entry["frame_offset"] = int(offsets[i])
        else:
            entry["file"] = rel(v.path)
    if m.env_path:
        env = m.env_path
        if os.path.basename(env).startswith("vsd_env_"):  # a packed/generated image
            dst = os.path.splitext(os.path.abspath(filepath))[0] + "_env.exr"
            shutil.copyfile(env, dst)
            env = dst
        sc["environment"]["file"] = rel(env)
    if _animated(scene.camera):
        m.warn("the camera is animated: the scene file holds its frame-%d position" % scene.frame_current)
    for v in m.volumes:
        if _animated(v.object.original):
            m.warn("volume object '%s' is animated: the scene file holds its frame-%d matrix"
                   % (v.object.name, scene.frame_current))
    sc["output"]["exr"] = rel(output_pattern(scene))
    # the exported frames are files kept on disk: ZIP, not the transient results' RLE
    sc["output"].pop("compression", None)
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
