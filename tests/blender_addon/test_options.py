# The add-on's method menus, option panels and warnings come from vsd's own catalog, in real
# Blender:
#   blender --background --factory-startup --python-exit-code 1 \
#       --python tests/blender_addon/test_options.py -- VSD SHARED_DATA TMP_DIR
#
# * enabling the add-on with the vsd binary in the preferences loads `vsd methods --json`;
# * the method menus list the catalog's methods, labels and summaries in its order, default
#   to its roles, and keep the choice by name;
# * every option of every method has a property with the table's type, default, range and
#   doc, and the panel draws a row for it when that method is picked, greyed out where its
#   "applies_when" rule does not hold (and then not sent);
# * only values set away from the defaults are sent (render.options), and they are what the
#   table's checker accepts: a real render through the daemon with one of them works;
# * warnings name the methods with the capability the scene needs, from the catalog;
# * the daemon's HELLO carries the same catalog;
# * the add-on here is installed by copying the repository's folder into the addons folder
#   (as a developer does with a checkout); the other add-on tests install the zip.
import json
import os
import subprocess
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

vsd, data, tmp, _ = common.args()
common.fresh_tmp(tmp)
catalog = json.loads(subprocess.run([vsd, "methods", "--json"], capture_output=True, check=True).stdout)
names = [m["name"] for m in catalog]
table = {m["name"]: m["options"] for m in catalog}
check(set(names) >= {"reference", "raymarch", "constellation", "shgrid"}, "vsd methods --json lists the methods")

common.install_addon(tmp, vsd=vsd, by_copy=True)
import vsd_blender  # noqa: E402
from vsd_blender import mapping, method_catalog, ui  # noqa: E402

check(method_catalog.catalog() == catalog, "the add-on loaded the catalog from the vsd binary (%s)"
      % method_catalog.source())
scene = bpy.context.scene
scene.render.engine = "VSD"

# the menus: the catalog's methods in its order, with its labels and summaries
# (a menu with an items function has no static enum_items: ask it, and ask the UI as a menu does)
items = [i[:3] for i in method_catalog.menu_items(scene.vsd, bpy.context)]
check(items == [(m["name"], m["label"], m["summary"]) for m in catalog],
      "the method menu is the catalog (%s)" % [i[0] for i in items])
shown = [(bpy.types.UILayout.enum_item_name(scene.vsd, "method", m["name"]),
          bpy.types.UILayout.enum_item_description(scene.vsd, "viewport_method", m["name"])) for m in catalog]
check(shown == [(m["label"], m["summary"]) for m in catalog], "both menus show the labels and summaries (%s)" % shown)
role = {r: m["name"] for m in catalog for r in m["roles"]}
check(scene.vsd.method == role["final_default"] and scene.vsd.viewport_method == role["viewport_default"],
      "the menus default to the catalog's roles (%s, %s)" % (scene.vsd.method, scene.vsd.viewport_method))
scene.vsd.method = names[-1]
check(scene.vsd.method == names[-1] and scene.vsd.method_name == names[-1], "the choice is kept by name")
scene.vsd.method = role["final_default"]

for method, rows in table.items():
    group = getattr(scene.vsd_options, method, None)
    check(group is not None, "Scene.vsd_options.%s exists" % method)
    if group is None:
        continue
    for row in rows:
        key = row["key"]
        p = group.bl_rna.properties.get(key)
        check(p is not None, "%s.%s is a property" % (method, key))
        if p is None:
            continue
        expect_type = {"int": "INT", "number": "FLOAT", "bool": "BOOLEAN", "choice": "ENUM"}[row["type"]]
        check(p.type == expect_type, "%s.%s is %s" % (method, key, expect_type))
        check(row["doc"] in p.description, "%s.%s carries the table's doc" % (method, key))
        value = getattr(group, key)
        if row["type"] in ("int", "number"):
            check(abs(value - row["default"]) <= 1e-6 * max(1.0, abs(row["default"])),
                  "%s.%s defaults to %s (got %s)" % (method, key, row["default"], value))
            lo = 0 if row.get("auto_zero") else row["min"]   # 0 = automatic stays settable
            check(abs(p.hard_min - lo) < 1e-6, "%s.%s minimum %s (got %s)" % (method, key, lo, p.hard_min))
        elif row["type"] == "choice":
            check(value == row["default"] and [i.identifier for i in p.enum_items] == row["choices"],
                  "%s.%s offers %s, default %s" % (method, key, row["choices"], row["default"]))
        else:
            check(value == row["default"], "%s.%s defaults to %s" % (method, key, row["default"]))
    # the panel draws one row per option for the picked method
    scene.vsd.method = method
    panel = common.FakePanel()
    ui.RENDER_PT_vsd_options.draw(panel, bpy.context)
    drawn = [r[2] for r in panel.layout.rows if r[0] == "prop" and r[1] == group]
    check(drawn == [r["key"] for r in rows], "the panel draws %s's rows %s (drew %s)" % (
        method, [r["key"] for r in rows], drawn))

# a row whose rule does not hold is greyed out and not sent: every rule of the catalog, one
# condition broken at a time (the others at their defaults)
ruled = 0
for m in catalog:
    scene.vsd.method = m["name"]
    group = getattr(scene.vsd_options, m["name"])
    rows_by_key = {r["key"]: r for r in m["options"]}
    for row in m["options"]:
        for cond in row.get("applies_when", []):
            other = rows_by_key[cond["key"]]
            if "differs" in cond:
                bad = cond["differs"]
            elif other["type"] == "choice":
                bad = [c for c in other["choices"] if c != cond["equals"]][0]
            elif other["type"] == "bool":
                bad = not cond["equals"]
            else:
                bad = other["max"] if cond["equals"] != other["max"] else other["min"]
            setattr(group, cond["key"], bad)
            panel = common.FakePanel()
            ui.RENDER_PT_vsd_options.draw(panel, bpy.context)
            check(row["key"] in panel.layout.inactive and cond["key"] not in panel.layout.inactive,
                  "%s.%s is greyed out with %s = %r" % (m["name"], row["key"], cond["key"], bad))
            # set away from its default, it is still not sent: vsd would refuse it
            if row["type"] == "choice":
                setattr(group, row["key"], [c for c in row["choices"] if c != row["default"]][0])
            elif row["type"] == "bool":
                setattr(group, row["key"], not row["default"])
            else:
                setattr(group, row["key"], row["max"] if row["default"] != row["max"] else row["min"])
            sent = mapping.render_block(scene.vsd)["options"]
            check(row["key"] not in sent, "%s.%s is not sent where it does not apply (%s)" % (m["name"], row["key"], sent))
            group.property_unset(row["key"])
            group.property_unset(cond["key"])
            ruled += 1
check(ruled > 0, "the catalog has rules (%d conditions)" % ruled)
scene.vsd.method = role["final_default"]

# warnings name the methods with the capability, from the catalog
refracting = [m for m in catalog if m["capabilities"]["refraction"]]
flat = [m for m in catalog if not m["capabilities"]["refraction"]][0]
scene.vsd.method = flat["name"]
scene.vsd.ior = 1.3
panel = common.FakePanel()
ui.RENDER_PT_vsd.draw(panel, bpy.context)
labels = [r[2] for r in panel.layout.rows if r[0] == "label"]
want = "Only %s refract" % " and ".join(m["label"] for m in refracting)
check(want in labels, "the IOR row warns %r (drew %s)" % (want, labels))
single = [t for t in labels if t and "Scatters light once" in t]
check(bool(single) == (not flat["capabilities"]["multiple_scattering"]),
      "a single-scattering method is said to scatter once (%s)" % single)
scene.vsd.ior = 1.0
scene.vsd.method = role["final_default"]

# nothing set: no options sent; set ones are sent with their JSON types
scene.vsd.method = "constellation"
check(mapping.render_block(scene.vsd)["options"] == {}, "defaults send no options")
scene.vsd_options.constellation.lights = 16
scene.vsd_options.constellation.distance_map = False
scene.vsd_options.constellation.lights_method = "kmeans"
opts = mapping.render_block(scene.vsd)["options"]
check(opts == {"lights": 16, "distance_map": False, "lights_method": "kmeans"}, "set options are sent: %s" % opts)
# a number is kept in single precision: its untouched default is not sent, a change is
scene.vsd_options.constellation.view_threshold = 0.3
opts = mapping.render_block(scene.vsd)["options"]
check(abs(opts.get("view_threshold", 0.0) - 0.3) < 1e-6, "a changed number is sent: %s" % opts)
scene.vsd_options.constellation.view_threshold = 0.15
check("view_threshold" not in mapping.render_block(scene.vsd)["options"],
      "a number set back to its default (0.15, stored as 0.15000000596) is not sent")
scene.vsd.options_json = '{"lights": 8}'
check(mapping.render_block(scene.vsd)["options"]["lights"] == 8, "the JSON field overrides a row")
scene.vsd.options_json = ""

# the daemon's HELLO carries the same table, and a render with a generated option works
d = common.Daemon(vsd, tmp)
try:
    prefs = common.addon_prefs()
    prefs.address = d.sock
    st = vsd_blender.connection.refresh_status(vsd_blender.connection.Settings.from_prefs(prefs))
    check(st["ok"], "connected to the daemon: %s" % st["text"])
    c = vsd_blender.connection.client(vsd_blender.connection.Settings.from_prefs(prefs))
    check(c.server.get("method_catalog") == catalog, "HELLO.method_catalog equals `vsd methods --json`")
    check(c.server.get("method_options") == table, "HELLO.method_options equals the catalog's options")
    scene2, ob = common.build_scene(data, width=48, height=27)   # replaces the objects of this scene
    scene2.vsd.method = "raymarch"
    scene2.vsd_options.raymarch.lights = 4
    scene2.vsd_options.raymarch.pixel_samples = 2   # the default is 1: only changed values are sent
    block = mapping.render_block(scene2.vsd)
    check(block["options"] == {"lights": 4, "pixel_samples": 2}, "raymarch options sent: %s" % block["options"])
    # the refractive index is sent as medium.ior (default 1: straight rays)
    check(mapping.build_scene(bpy.context.evaluated_depsgraph_get()).scene["volumes"][0]["medium"]["ior"] == 1.0,
          "medium.ior defaults to 1")
    scene2.vsd.ior = 1.25
    sent = mapping.build_scene(bpy.context.evaluated_depsgraph_get()).scene["volumes"][0]["medium"]["ior"]
    check(abs(sent - 1.25) < 1e-6, "Scene.vsd.ior is sent as medium.ior (%s)" % sent)
    # the world's Environment Texture interpolation: Blender's default Linear, then Closest
    env_tex = [n for n in scene2.world.node_tree.nodes if n.type == "TEX_ENVIRONMENT"][0]
    sent = mapping.build_scene(bpy.context.evaluated_depsgraph_get()).scene["environment"]["interpolation"]
    check(env_tex.interpolation == "Linear" and sent == "linear", "Linear is sent as linear (%s)" % sent)
    env_tex.interpolation = "Closest"
    sent = mapping.build_scene(bpy.context.evaluated_depsgraph_get()).scene["environment"]["interpolation"]
    check(sent == "closest", "Closest is sent as closest (%s)" % sent)
    env_tex.interpolation = "Linear"
    scene2.vsd.ior = 1.0
    images = []
    for lights in (4, 1):
        scene2.vsd_options.raymarch.lights = lights
        out = os.path.join(tmp, "options_%d.exr" % lights)
        err = common.run_blender_render(out)
        check(err is None, "F12 with raymarch lights=%d (%s)" % (lights, err))
        images.append(common.read_exr(out)[0] if err is None else {})
    key = [k for k in images[0] if k.endswith(".%s.R" % common.blender_pass("VolumeDir"))]
    check(bool(key) and images[0][key[0]] != images[1].get(key[0]),
          "the generated option reaches the renderer (lights 4 and 1 give different VolumeDir)")
finally:
    d.stop()
common.finish("blender_addon_options")
