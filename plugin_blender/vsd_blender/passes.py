# The render passes vsd returns and the names each Blender version gives them, in one table.
#
# Blender matches passes by their full channel name "<view layer>.<pass>.<channel>" when
# RenderResult.load_from_file() fills a render result, so the name the add-on registers in
# update_render_passes must be the name in the file the daemon writes. vsd's own names
# (first column) are Blender 3.4's and 4.x's. Blender 5.0 renamed the built-in passes
# (blenloader versioning_500.cc, legacy_pass_name_to_new_name: VolumeDir -> "Volume Direct",
# VolumeInd -> "Volume Indirect", Emit -> "Emission"; Combined and Depth keep their names,
# Transmittance is vsd's own); Cycles 5.0.1 writes exactly these names (tests/blender_addon/
# test_versions.py renders with each tested version's Cycles and compares). The add-on therefore sends output.pass_names, the map
# pass_names(bpy.app.version), with every request and export, and the daemon names its EXR
# layers after it (docs/scene-file.md, docs/blender-addon.md "Later Blender versions").
#
# This module imports nothing from Blender, so tests/blender_addon/test_passes.py checks the
# table with plain Python.

# (vsd pass name, channel count, channel ids, Blender pass type)
PASSES = (
    ("Combined", 4, "RGBA", "COLOR"),
    ("VolumeDir", 3, "RGB", "COLOR"),
    ("VolumeInd", 3, "RGB", "COLOR"),
    ("Emit", 3, "RGB", "COLOR"),
    ("Transmittance", 3, "RGB", "COLOR"),
    ("Depth", 1, "Z", "VALUE"),
)

VSD_PASS_NAMES = tuple(p[0] for p in PASSES)

# Blender version (major, minor) from which a renaming applies -> {vsd name: Blender name}.
# Versions before the first entry use vsd's names unchanged; a later row adds to (and may
# override) the earlier ones.
BLENDER_NAMES = (
    ((5, 0), {"VolumeDir": "Volume Direct", "VolumeInd": "Volume Indirect", "Emit": "Emission"}),
)


def blender_pass_name(vsd_name, version):
    """The name Blender `version` (a tuple like bpy.app.version) uses for vsd pass `vsd_name`."""
    if vsd_name not in VSD_PASS_NAMES:
        raise KeyError("not a vsd pass: %r" % (vsd_name,))
    name = vsd_name
    for since, table in BLENDER_NAMES:
        if tuple(version[:2]) >= since:
            name = table.get(vsd_name, name)
    return name


def pass_names(version):
    """output.pass_names for Blender `version`: {vsd pass: EXR layer name}, every pass."""
    return {n: blender_pass_name(n, version) for n in VSD_PASS_NAMES}


def registered_passes(version):
    """(Blender name, channels, chan ids, type) for update_render_passes."""
    return [(blender_pass_name(n, version), c, ids, t) for n, c, ids, t in PASSES]
