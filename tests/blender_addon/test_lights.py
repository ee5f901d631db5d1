# The add-on sends Blender's lights (issue 14: "the scene's sun, point and spot lights"), in
# real Blender:
#   blender --background --factory-startup --python-exit-code 1 \
#       --python tests/blender_addon/test_lights.py -- VSD SHARED_DATA TMP_DIR
#
# * a sun, a point and a spot become lights[] entries with Blender's values in Cycles'
#   units (Strength W/m^2, Power W), the position from matrix_world and the direction from
#   its local -Z; an area light, and a light's node tree, are notes; hidden lights are not
#   sent;
# * a method that does not render lights (raymarch) gets none, with a note naming the ones
#   that do; so does a refracting medium;
# * F12 through the daemon with reference: the point light brightens VolumeDir against the
#   same render without it; File > Export > vsd scene carries the lights and `vsd render`
#   renders the export.
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402
import mathutils  # noqa: E402


def close(a, b, eps=1e-5):
    return len(a) == len(b) and all(abs(x - y) <= eps for x, y in zip(a, b))


def add_light(name, kind, location, target=None, **props):
    light = bpy.data.lights.new(name, kind)
    for k, v in props.items():
        setattr(light, k, v)
    ob = bpy.data.objects.new(name, light)
    bpy.context.scene.collection.objects.link(ob)
    ob.matrix_world = common.look_at_matrix(location, target) if target else mathutils.Matrix.Translation(location)
    return ob


def main():
    vsd, data, tmp = common.start_test()
    mapping = common.addon_module("mapping")
    with common.addon_daemon(vsd, tmp) as d:
        scene, ob = common.build_scene(data, width=32, height=18)
        s = scene.vsd
        s.method = "reference"

        def sent():
            m = mapping.build_scene(bpy.context.evaluated_depsgraph_get())
            return m.scene, m.warnings

        sc, warnings = sent()
        check(sc["lights"] == [] and not warnings, "no lights: lights [] (%s)" % warnings)

        # --- the three types -----------------------------------------------------------------
        sun = add_light("sun", "SUN", (0, 0, 5), (1.0, 2.0, 0.0), energy=3.5, angle=math.radians(2.0),
                        color=(1.0, 0.9, 0.8))
        point = add_light("lamp", "POINT", (2.5, -0.5, 2.5), energy=400.0, shadow_soft_size=0.2,
                          color=(1.0, 0.7, 0.4))
        spot = add_light("spot", "SPOT", (-2.5, 1.0, 0.8), (1.0, 1.0, 1.0), energy=900.0, shadow_soft_size=0.0,
                         spot_size=math.radians(40.0), spot_blend=0.3)
        sc, warnings = sent()
        by_type = {e["type"]: e for e in sc["lights"]}
        check(len(sc["lights"]) == 3 and set(by_type) == {"sun", "point", "spot"}, "three lights sent (%s)" % sc["lights"])
        sd = mathutils.Vector((1.0, 2.0, 0.0)) - mathutils.Vector((0, 0, 5))
        sd.normalize()
        e = by_type.get("sun", {})
        check(e.get("strength") == 3.5 and close(e.get("direction", []), list(sd)) and
              abs(e.get("angle", 0) - math.radians(2.0)) < 1e-6 and close(e.get("color", []), [1.0, 0.9, 0.8]),
              "sun: strength, the direction it shines (local -Z), angle, colour (%s)" % e)
        check(set(e) == {"type", "color", "strength", "direction", "angle"}, "sun: only a sun's keys (%s)" % sorted(e))
        e = by_type.get("point", {})
        check(e.get("power") == 400.0 and close(e.get("position", []), [2.5, -0.5, 2.5]) and
              abs(e.get("radius", 0) - 0.2) < 1e-6 and set(e) == {"type", "color", "power", "position", "radius"},
              "point: power, position, radius (%s)" % e)
        e = by_type.get("spot", {})
        spd = mathutils.Vector((1.0, 1.0, 1.0)) - mathutils.Vector((-2.5, 1.0, 0.8))
        spd.normalize()
        check(e.get("power") == 900.0 and close(e.get("direction", []), list(spd)) and
              abs(e.get("spot_size", 0) - math.radians(40.0)) < 1e-6 and abs(e.get("spot_blend", 0) - 0.3) < 1e-6,
              "spot: power, direction, size, blend (%s)" % e)
        check(not warnings, "no notes for the three (%s)" % warnings)

        area = add_light("panel", "AREA", (0, 0, 4), energy=100.0)
        sc, warnings = sent()
        check(len(sc["lights"]) == 3 and any("'panel'" in w and "area lights are not supported" in w for w in warnings),
              "an area light is a note, not sent (%s)" % warnings)
        bpy.data.objects.remove(area, do_unlink=True)
        point.data.use_nodes = True
        sc, warnings = sent()
        check(any("'lamp'" in w and "node tree" in w for w in warnings), "a light's node tree is a note (%s)" % warnings)
        point.data.use_nodes = False
        spot.hide_render = True
        sc, _ = sent()
        check(len(sc["lights"]) == 2 and "spot" not in {e["type"] for e in sc["lights"]}, "a hidden light is not sent")
        spot.hide_render = False

        # --- who renders them -------------------------------------------------------------------
        s.method = "raymarch"
        sc, warnings = sent()
        # the note names the method and those that render lights, by the catalog's labels
        catalog = common.addon_module("method_catalog")
        want = "method %s does not render lights: 3 ignored (%s render them)" % (
            catalog.label("raymarch"), catalog.labels_with("scene_lights"))
        check(sc["lights"] == [] and want in warnings and "Reference" in catalog.labels_with("scene_lights"),
              "raymarch: none sent, a note (%s)" % warnings)
        s.method = "lbl"
        sc, warnings = sent()
        check(len(sc["lights"]) == 3 and not warnings, "lbl: the three sent (%s)" % warnings)
        s.ior = 1.2
        sc, warnings = sent()
        check(sc["lights"] == [] and any("refracting medium" in w for w in warnings),
              "a refracting medium: none sent, a note (%s)" % warnings)
        s.ior = 1.0

        # --- F12: the lamp brightens the smoke ------------------------------------------------
        s.method, s.samples = "reference", 16
        for o in (sun, spot):
            o.hide_render = True
        point.data.energy = 3000.0
        lit = os.path.join(tmp, "lit.exr")
        dark = os.path.join(tmp, "dark.exr")
        err = common.run_blender_render(lit)
        check(err is None, "F12 with a point light (%s)" % err)
        point.hide_render = True
        err2 = common.run_blender_render(dark)
        check(err2 is None, "F12 without it (%s)" % err2)
        point.hide_render = False
        if err is None and err2 is None:
            a, w, h = common.read_exr(lit)
            b, _, _ = common.read_exr(dark)
            key = [k for k in a if k.endswith(".%s.R" % common.blender_pass("VolumeDir"))][0]
            sa, sb = sum(a[key]), sum(b[key])
            print("VolumeDir red sum with the lamp %.4g, without %.4g" % (sa, sb))
            check(sa > 1.5 * sb, "the 3000 W lamp brightens VolumeDir (%.4g vs %.4g)" % (sa, sb))

        ex, r = common.export_and_render(vsd, tmp, "lights")
        check(len(ex.get("lights", [])) == 1 and ex["lights"][0]["type"] == "point" and ex["lights"][0]["power"] == 3000.0,
              "the export carries the visible light (%s)" % ex.get("lights"))
        check(r.returncode == 0, "vsd render renders the exported lights (%s)" % r.stderr.strip())
    common.finish("blender_addon_lights")


main()
