# The render passes vsd returns and the names Blender gives them, in one table.
#
# vsd's daemon names its EXR channels `<view layer>.<pass>.<channel>` with the pass names of
# the first column (DESIGN.md §6). Blender matches passes by that full name when
# RenderResult.load_from_file() fills a render result, so the name the add-on registers must
# be the name in the file. Blender 3.4 and 4.x call the volume passes VolumeDir/VolumeInd,
# exactly vsd's names; Blender 5.0 renamed them for display ("Volume Direct", ...). A later
# Blender only needs a row in BLENDER_NAMES (and the daemon's channels renamed to match, see
# docs/blender-addon.md "Later Blender versions").

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
# Versions before the first entry use vsd's names unchanged.
BLENDER_NAMES = (
    ((5, 0), {"VolumeDir": "Volume Direct", "VolumeInd": "Volume Indirect", "Emit": "Emission"}),
)


def blender_pass_name(vsd_name, version):
    """The name Blender `version` (a tuple like bpy.app.version) uses for vsd pass `vsd_name`."""
    name = vsd_name
    for since, table in BLENDER_NAMES:
        if tuple(version[:2]) >= since:
            name = table.get(vsd_name, vsd_name)
    return name


def names_match(version):
    """True when every vsd pass has the same name in this Blender (the EXR loads as is)."""
    return all(blender_pass_name(n, version) == n for n in VSD_PASS_NAMES)


def registered_passes(version):
    """(Blender name, channels, chan ids, type) for update_render_passes."""
    return [(blender_pass_name(n, version), c, ids, t) for n, c, ids, t in PASSES]
