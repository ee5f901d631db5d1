# The add-on's pass-name table (plugin_blender/vsd_blender/passes.py), without Blender:
# * Blender 3.4 and 4.x: every pass keeps vsd's name (the names Blender 3.4 writes);
# * Blender 5.0 and later: "Volume Direct", "Volume Indirect", "Emission" (Blender's
#   versioning_500.cc), Combined / Transmittance / Depth unchanged;
# * the names registered with Blender are the names sent as output.pass_names, so the EXR the
#   daemon writes loads with RenderResult.load_from_file;
# * every version's names obey the rules the scene parser enforces (core/src/scene/scene.c
#   apply_pass_names): non-empty, at most 63 bytes, no '.', all distinct.
# Usage: python3 tests/blender_addon/test_passes.py   (exit 0 = all checks passed)
import importlib.util
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
PATH = os.path.join(os.path.dirname(os.path.dirname(HERE)), "plugin_blender", "vsd_blender", "passes.py")
spec = importlib.util.spec_from_file_location("vsd_passes", PATH)
passes = importlib.util.module_from_spec(spec)
spec.loader.exec_module(passes)  # the module must not need bpy

failures = []


def check(cond, what):
    print(("ok:   " if cond else "FAIL: ") + what)
    if not cond:
        failures.append(what)


VSD = ("Combined", "VolumeDir", "VolumeInd", "Emit", "Transmittance", "Depth")
check(passes.VSD_PASS_NAMES == VSD, "vsd's passes in the daemon's order: %s" % (passes.VSD_PASS_NAMES,))

for version in ((3, 4, 1), (3, 6, 0), (4, 0, 2), (4, 5, 3)):
    names = passes.pass_names(version)
    check(names == {n: n for n in VSD}, "Blender %s keeps vsd's names: %s" % (version, names))

renamed = {"Combined": "Combined", "VolumeDir": "Volume Direct", "VolumeInd": "Volume Indirect",
           "Emit": "Emission", "Transmittance": "Transmittance", "Depth": "Depth"}
for version in ((5, 0, 0), (5, 1, 0), (6, 0, 0)):
    names = passes.pass_names(version)
    check(names == renamed, "Blender %s names: %s" % (version, names))

for version in ((3, 4, 1), (5, 0, 0)):
    reg = passes.registered_passes(version)
    sent = passes.pass_names(version)
    check([r[0] for r in reg] == [sent[n] for n in VSD],
          "Blender %s: registered passes = output.pass_names (%s)" % (version, [r[0] for r in reg]))
    check([(r[1], r[2]) for r in reg] == [(4, "RGBA"), (3, "RGB"), (3, "RGB"), (3, "RGB"), (3, "RGB"), (1, "Z")],
          "Blender %s: channel counts and ids" % (version,))

versions = [(3, 4, 0)] + [tuple(since) + (0,) for since, _ in passes.BLENDER_NAMES]
for version in versions:
    vals = list(passes.pass_names(version).values())
    ok = all(v and len(v.encode()) <= 63 and "." not in v for v in vals) and len(set(vals)) == len(vals)
    check(ok, "Blender %s: names non-empty, <= 63 bytes, no '.', distinct" % (version,))

try:
    passes.blender_pass_name("Volume Direct", (5, 0, 0))
    check(False, "an unknown vsd pass raises KeyError")
except KeyError:
    check(True, "an unknown vsd pass raises KeyError")

if failures:
    print("test_passes: %d check(s) failed" % len(failures))
    sys.exit(1)
print("test_passes: all checks passed")
