# Several volume objects in one scene (issue 30), in real Blender:
#   blender --background --factory-startup --python-exit-code 1 \
#       --python tests/blender_addon/test_volumes.py -- VSD SHARED_DATA TMP_DIR
#
# Three Volume objects side by side: smoke64 as two sequences with different Frame Start /
# Offset and materials, and fire96 frame 48 with its flame grid as emission. Beside them,
# in view, four that must not go: one disabled for renders, a holdout object, one in a
# holdout collection, one whose material has no volume shader.
# * the mapping: `volumes` holds the three in name order, each with its current frame's
#   file, its matrix (matrix_world with the half-voxel shift before 5.0) and its medium; no
#   `volume`/`medium`; the others are absent, each left out with a note; no note about
#   volumes not rendered; the viewport takes the render-disabled one (it shows it); a volume
#   without any material goes with Principled Volume defaults (as Cycles renders it); a
#   sequence showing no file at the frame (Clip) is left out with a note; 17 volumes are an
#   error naming 17 and the limit 16;
# * the method: with one that renders one volume, F12 is an error naming it and the
#   catalog's methods that render several, the viewport shows its own default (LBL) when
#   that renders several, else the first that does, instead and says so (status text, overlay), the menus mark it, the panel
#   says F12 refuses the scene, the export warns; with the viewport's default (lbl, which
#   renders several) the preview renders the four volumes with it;
# * File > Export: each volume as its #### pattern with its frame_offset, frames numbered
#   by scene frame; `vsd render` renders the export;
# * F12 with the method that renders several (reference): alpha in each of the three
#   objects' screen regions, emission only in the fire's, nothing anywhere else (where the
#   four left out stand) — and the same picture as `vsd render` of the export.
import json
import os
import re
import subprocess
import sys
import types

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402
import mathutils  # noqa: E402
from bpy_extras.object_utils import world_to_camera_view  # noqa: E402

W, H = 160, 90
FRAME = 20
SEVERAL = "several_volumes"


def density_bbox(vsd, path, grid="density"):
    """The world bbox of a file's grid (object space of its Volume object), from `vsd info`."""
    out = subprocess.run([vsd, "info", path], capture_output=True, text=True, check=True).stdout
    part = out.split("grid ")[1:]
    for p in part:
        if p.split(":", 1)[1].strip().startswith(grid):
            mm = re.search(r"world bbox\s+\[([^\]]+)\]\s+\.\.\s+\[([^\]]+)\]", p)
            return [float(x) for x in mm.group(1).split()], [float(x) for x in mm.group(2).split()]
    raise AssertionError("no grid %s in %s" % (grid, path))


def add_volume(name, path, location, scale=1.0, sequence=None, material=None, collection=None):
    vol = bpy.data.volumes.new(name)
    vol.filepath = path
    if sequence:
        vol.is_sequence = True
        vol.frame_start, vol.frame_offset = sequence
        vol.frame_duration = 30
        vol.sequence_mode = "CLIP"
    ob = bpy.data.objects.new(name, vol)
    (collection or bpy.context.scene.collection).objects.link(ob)
    ob.matrix_world = mathutils.Matrix.Translation(location) @ mathutils.Matrix.Scale(scale, 4)
    if material is not None:
        vol.materials.append(material)
    return ob


def principled(name, density, color, anisotropy, emission=None):
    """A material with a Principled Volume; emission = (grid, strength, colour): an Attribute
    node times the strength into Emission Strength."""
    mat = bpy.data.materials.new(name)
    nt = common.empty_node_tree(mat)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Density"].default_value = density
    pv.inputs["Color"].default_value = tuple(color) + (1.0,)
    pv.inputs["Anisotropy"].default_value = anisotropy
    nt.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    if emission:
        grid, strength, ecol = emission
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.attribute_name = grid
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = "MULTIPLY"
        mul.inputs[1].default_value = strength
        nt.links.new(attr.outputs[0], mul.inputs[0])
        nt.links.new(mul.outputs["Value"], pv.inputs["Emission Strength"])
        pv.inputs["Emission Color"].default_value = tuple(ecol) + (1.0,)
    return mat


def surface_only(name):
    mat = bpy.data.materials.new(name)
    nt = common.empty_node_tree(mat)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat


def screen_box(scene, ob, bbox, margin=1):
    """(x0, y0, x1, y1) pixel box, rows from the top, of the object's bbox corners."""
    lo, hi = bbox
    xs, ys = [], []
    for cx in (lo[0], hi[0]):
        for cy in (lo[1], hi[1]):
            for cz in (lo[2], hi[2]):
                p = world_to_camera_view(scene, scene.camera, ob.matrix_world @ mathutils.Vector((cx, cy, cz)))
                xs.append(p.x * W)
                ys.append((1.0 - p.y) * H)
    return (int(min(xs)) - margin, int(min(ys)) - margin, int(max(xs)) + 1 + margin, int(max(ys)) + 1 + margin)


def in_box(i, box):
    x, y = i % W, i // W
    return box[0] <= x < box[2] and box[1] <= y < box[3]


def one_volume_method(scene, s, tmp, one, fallback, build):
    """A method that renders one volume, with the scene's three (four in the viewport): F12
    refuses, the menus and panels say so, the viewport falls back to `fallback`, the export
    warns."""
    mapping = common.addon_module("mapping")
    catalog = common.addon_module("method_catalog")
    s.method = one
    try:
        build()
        err = None
    except mapping.MappingError as ex:
        err = str(ex)
    check(err is not None and ("method %s renders one volume" % catalog.label(one)) in err and "3 volumes" in err
          and catalog.labels_with(SEVERAL) in err,
          "F12 mapping with %s: an error naming it and %s (%s)" % (one, catalog.labels_with(SEVERAL), err))
    ferr = common.run_blender_render()
    check(ferr is not None and catalog.label(one) in ferr and catalog.labels_with(SEVERAL) in ferr,
          "F12 with %s: Blender's error names it and the methods that can (%s)" % (one, ferr))
    # the menus and the panel say so
    ctx = types.SimpleNamespace(view_layer=bpy.context.view_layer)
    items = {it[0]: it for it in catalog.menu_items(s, ctx)}
    check(items[one][1].endswith("(one volume)") and "F12 refuses" in items[one][2] and
          not items[fallback][1].endswith("(one volume)"),
          "the F12 menu marks %s (%r) and not %s" % (one, items[one][1], fallback))
    vitems = {it[0]: it for it in catalog.viewport_menu_items(s, ctx)}
    check(vitems[one][1].endswith("(one volume)") and ("shows %s" % catalog.label(fallback)) in vitems[one][2],
          "the viewport menu marks %s with what it shows instead (%r)" % (one, vitems[one][2]))
    check(not any(it[1].endswith("(one volume)") for it in catalog.menu_items(None, None)),
          "no marks without a context (a single-volume scene's menu is unchanged)")
    ui = common.addon_module("ui")
    panel = common.FakePanel()
    ui.RENDER_PT_vsd.draw(panel, bpy.context)
    labels = [r[2] for r in panel.layout.rows if r[0] == "label"]
    check(any(("%s renders one volume: F12 refuses these 3" % catalog.label(one)) in (t or "") for t in labels),
          "the vsd panel says F12 refuses the scene (%s)" % labels)
    # the viewport falls back, and says so
    s.viewport_method = one
    mv = build(viewport=True, size=(8, 8))
    status = "%s renders one volume; showing %s for 4 volumes" % (catalog.label(one), catalog.label(fallback))
    check(mv.scene["render"].get("method") == fallback and status in mv.warnings,
          "the viewport renders with %s and says '%s' (%s)" % (fallback, status, mv.warnings))
    viewport = common.addon_module("viewport")
    p = viewport.Preview()
    try:
        p.scene_changed(bpy.context, bpy.context.evaluated_depsgraph_get())
        check(("vsd: " + status, (1.0, 0.85, 0.3, 1.0)) in p.overlay_lines() and p.error is None,
              "the preview draws the fallback over the picture (%s)" % p.overlay_lines())
    finally:
        p.stop()
    panel = common.FakePanel()
    ui.RENDER_PT_vsd_viewport.draw(panel, bpy.context)
    labels = [r[2] for r in panel.layout.rows if r[0] == "label"]
    check(sum(1 for t in labels if status in (t or "")) == 1, "the Viewport panel says so too, once (%s)" % labels)
    s.viewport_method = "reference"
    # the export keeps the method, with a warning (vsd render would refuse it)
    path1 = os.path.join(tmp, "export", "one_method.json")
    os.makedirs(os.path.dirname(path1), exist_ok=True)
    mod_export = common.addon_module("export")
    _, ew = mod_export.export_scene(bpy.context, path1, frame_range=False)
    check(any(("method %s renders one volume" % catalog.label(one)) in w and "--method reference" in w for w in ew),
          "the export with %s warns that vsd render refuses it (%s)" % (one, ew))
    s.method = "reference"


def main():
    vsd, data, tmp = common.start_test()
    mapping = common.addon_module("mapping")
    catalog = common.addon_module("method_catalog")
    smoke = os.path.join(data, "smoke64", "fluid_data_0001.vdb")
    fire = os.path.join(data, "fire96", "fluid_data_0048.vdb")
    smoke_bb = density_bbox(vsd, os.path.join(data, "smoke64", "fluid_data_%04d.vdb" % (FRAME + 2)))
    fire_bb = density_bbox(vsd, fire)

    # --- the scene: common's smoke becomes "A smoke"; B, C beside it; four left out above ----
    scene, a = common.build_scene(data, width=W, height=H, frame_start=FRAME - 2, frame_offset=0,
                                  cam_pos=(1.0, -8.0, 1.4), cam_target=(1.0, 1.0, 1.4), lens=30.0)
    a.name = a.data.name = "A smoke"
    a.data.frame_start, a.data.frame_offset = 1, 2          # scene frame f shows file f + 2
    a.matrix_world = mathutils.Matrix.Translation((-2.0, 0.0, 0.0))
    scene.frame_set(FRAME)
    mat_b = principled("b_mat", 12.0, (0.3, 0.5, 0.9), -0.3)
    b = add_volume("B smoke", smoke, (0.0, 0.0, 0.0), sequence=(5, 3), material=mat_b)   # file f - 1
    mat_c = principled("c_mat", 6.0, (0.9, 0.9, 0.9), 0.1, emission=("flame", 5.0, (1.0, 0.4, 0.1)))
    c = add_volume("C fire", fire, (2.4, 0.0, 0.0), material=mat_c)
    mat_a = a.active_material
    d = add_volume("D not for renders", smoke, (-1.5, 0.0, 2.6), 0.5, sequence=(1, 0), material=mat_a)
    d.hide_render = True
    e = add_volume("E holdout", smoke, (0.5, 0.0, 2.6), 0.5, sequence=(1, 0), material=mat_a)
    e.is_holdout = True
    hcoll = bpy.data.collections.new("Holdouts")
    scene.collection.children.link(hcoll)
    f = add_volume("F in holdout collection", smoke, (2.5, 0.0, 2.6), 0.5, sequence=(1, 0), material=mat_a,
                   collection=hcoll)
    bpy.context.view_layer.layer_collection.children["Holdouts"].holdout = True
    g = add_volume("G surface only", smoke, (4.0, 0.0, 2.6), 0.5, sequence=(1, 0), material=surface_only("g_mat"))
    s = scene.vsd
    s.method = "reference"
    s.samples = 4
    s.viewport_method = "reference"

    def build(**kw):
        return mapping.build_scene(bpy.context.evaluated_depsgraph_get(), **kw)

    # --- what F12 sends ----------------------------------------------------------------------
    m = build()
    sc = m.scene
    print("sent:", json.dumps(sc["volumes"], indent=1))
    vols = sc.get("volumes", [])
    check("volume" not in sc and "medium" not in sc, "no single `volume`/`medium` beside `volumes`")
    check([v.object.name for v in m.volumes] == ["A smoke", "B smoke", "C fire"] and len(vols) == 3,
          "the three volumes go, in name order (%s)" % [v.object.name for v in m.volumes])
    if len(vols) == 3:
        want_files = [os.path.join(data, "smoke64", "fluid_data_%04d.vdb" % (FRAME + 2)),
                      os.path.join(data, "smoke64", "fluid_data_%04d.vdb" % (FRAME - 1)), fire]
        check([v["file"] for v in vols] == want_files,
              "each volume's current frame by its own Frame Start/Offset (%s)" % [v["file"] for v in vols])
        shift = mapping.voxel_centres_offset()
        for v, ob, h in zip(vols, (a, b, c), (1.0 / 32, 1.0 / 32, 2.0 / 96)):
            mw = ob.matrix_world
            t = [mw[r][3] + (h / 2 if shift else 0.0) for r in range(3)]
            mx = v["matrix"]
            check(all(abs(mx[4 * r + k] - mw[r][k]) < 1e-6 for r in range(3) for k in range(3)) and
                  all(abs(mx[4 * r + 3] - t[r]) < 1e-5 for r in range(3)),
                  "%s: matrix_world, moved by half a voxel before 5.0 (%s)" % (ob.name, [mx[3], mx[7], mx[11]]))
        ma, mb, mc = (v.get("medium", {}) for v in vols)
        check(abs(ma.get("density", 0) - 8.0) < 1e-6 and abs(mb.get("density", 0) - 12.0) < 1e-6 and
              abs(mc.get("density", 0) - 6.0) < 1e-6, "each its own density (8, 12, 6)")
        check([round(x, 5) for x in mb.get("albedo", [])] == [0.3, 0.5, 0.9] and
              abs(mb.get("anisotropy", 0) + 0.3) < 1e-6, "B's Color and Anisotropy (%s)" % mb)
        check(vols[2].get("emission_grid") == "flame" and abs(mc.get("emission_strength", 0) - 5.0) < 1e-6 and
              [round(x, 5) for x in mc.get("emission_color", [])] == [1.0, 0.4, 0.1] and
              "emission_grid" not in vols[0] and ma.get("emission_strength") == 0.0,
              "C's flame emission; A and B none (%s, %s)" % (vols[2].get("emission_grid"), mc))
        check(all("frame_offset" not in v for v in vols), "F12 sends each volume's resolved file, no frame_offset")
        check(all(v["medium"].get("ior", 1.0) == 1.0 for v in vols) and all("ior_grid" not in v for v in vols),
              "no refraction with several volumes")
    warns = m.warnings
    print("warnings:", warns)
    check(not any("renders one volume" in w or "not rendered: '" in w for w in warns),
          "no warning that a volume is not rendered (%s)" % warns)
    check(any("'E holdout' is a holdout" in w for w in warns) and
          any("'F in holdout collection' is a holdout" in w for w in warns),
          "holdout object and holdout collection: left out with a note")
    check(any("'G surface only'" in w and "no volume shader" in w for w in warns),
          "a material without a volume shader: left out with a note")
    check(not any("D not for renders" in w for w in warns), "the render-disabled volume: left out silently")
    check(mapping.count_volumes(scene, bpy.context.view_layer, True) == 3 and
          mapping.count_volumes(scene, bpy.context.view_layer, False) == 4,
          "count_volumes (panels, menus): 3 for F12, 4 for the viewport")

    # the viewport shows what it shows: D is disabled for renders only
    mv = build(viewport=True, size=(8, 8))
    check([v.object.name for v in mv.volumes] == ["A smoke", "B smoke", "C fire", "D not for renders"],
          "the viewport takes the render-disabled volume (%s)" % [v.object.name for v in mv.volumes])

    # a volume without any material: Cycles renders its default volume shader, so does vsd
    h_ob = add_volume("H no material", smoke, (0.0, 0.0, 5.0), sequence=(1, 0))
    mh = build()
    hv = [v.entry for v in mh.volumes if v.object.name == "H no material"]
    check(len(hv) == 1 and hv[0]["medium"]["density"] == 1.0 and hv[0]["medium"]["albedo"] == [0.5, 0.5, 0.5] and
          any("'H no material' has no material" in w for w in mh.warnings),
          "a volume without a material goes with Principled Volume defaults, with a note")
    bpy.data.objects.remove(h_ob, do_unlink=True)

    # a sequence that shows no file at this frame (Clip) is left out while others show
    scene.frame_set(3)      # before B's Frame Start (5): Clip shows nothing
    m3 = build()
    check([v.object.name for v in m3.volumes] == ["A smoke", "C fire"] and
          any("'B smoke' shows no file at frame 3" in w for w in m3.warnings),
          "a sequence showing nothing at the frame is left out with a note (%s)" % m3.warnings)
    scene.frame_set(FRAME)

    # more than 16: an error naming the count and the limit
    extra = [add_volume("X%02d" % i, smoke, (0.0, 5.0, 0.0), sequence=(1, 0), material=mat_a) for i in range(14)]
    try:
        build()
        err = None
    except mapping.MappingError as ex:
        err = str(ex)
    check(err is not None and "17 volume objects" in err and "at most 16" in err,
          "17 volumes: an error naming 17 and the limit 16 (%s)" % err)
    ferr = common.run_blender_render()
    check(ferr is not None and "17 volume objects" in ferr, "F12 with 17 volumes: Blender's error says so (%s)" % ferr)
    for ob in extra:
        bpy.data.objects.remove(ob, do_unlink=True)

    # --- a method that renders one volume ------------------------------------------------------
    single = [n for n in catalog.names() if not catalog.has(n, SEVERAL)]
    can = catalog.with_capability(SEVERAL)
    # the viewport's fallback: its own default when that renders several (interactive), else
    # the first method that does
    fallback = catalog.viewport_fallback()
    vd = catalog.default_for("viewport_default")
    expected = vd if catalog.has(vd, SEVERAL) else (can[0] if can else "")
    check(bool(can) and fallback == expected,
          "the catalog: methods with %s (%s), the viewport's fallback %s (expected %s); without it: %s"
          % (SEVERAL, can, fallback, expected, single))
    if single:
        one_volume_method(scene, s, tmp, "lbl" if "lbl" in single else single[0], fallback, build)
    else:
        print("note: every method renders several volumes: no refusal or fallback to check")

    # --- File > Export: patterns, frame offsets, scene frames ---------------------------------
    scene_json = os.path.join(tmp, "export", "three.json")
    res = bpy.ops.export_scene.vsd(filepath=scene_json)
    check(res == {"FINISHED"}, "export operator finished (%s)" % res)
    with open(scene_json) as fh:
        ex = json.load(fh)
    print("exported:", json.dumps({"volumes": ex.get("volumes"), "frames": ex.get("frames")}, indent=1))
    ev = ex.get("volumes", [])
    check(ex.get("frames") == {"start": FRAME - 2, "end": FRAME}, "frames: the scene's %d-%d (%s)"
          % (FRAME - 2, FRAME, ex.get("frames")))
    check(len(ev) == 3 and ev[0]["file"].endswith(os.path.join("smoke64", "fluid_data_####.vdb")) and
          ev[0].get("frame_offset") == 2 and ev[1]["file"] == ev[0]["file"] and ev[1].get("frame_offset") == -1 and
          ev[2]["file"].endswith("fluid_data_0048.vdb") and "frame_offset" not in ev[2],
          "each sequence as its pattern with its frame_offset (A +2, B -1), the still fire as its file")
    check(len(ev) == 3 and [v["medium"] for v in ev] == [v["medium"] for v in vols] and
          [v["matrix"] for v in ev] == [v["matrix"] for v in vols], "the export's media and matrices are F12's")
    cli = os.path.join(tmp, "cli_####.exr")
    r = subprocess.run([vsd, "render", scene_json, "--frames", "%d-%d" % (FRAME, FRAME), "--output", cli, "--quiet"],
                       capture_output=True, text=True)
    check(r.returncode == 0, "vsd render of the three-volume export (%s)" % r.stderr.strip())

    # --- F12 through the daemon ----------------------------------------------------------------
    with common.addon_daemon(vsd, tmp):
        out = os.path.join(tmp, "three.exr")
        ferr = common.run_blender_render(out)
        check(ferr is None, "F12 of three volumes with reference (%s)" % ferr)
        if ferr is None:
            img, w, h = common.read_exr(out)
            layer = bpy.context.view_layer.name
            alpha = img["%s.Combined.A" % layer]
            emit = img["%s.%s.R" % (layer, common.blender_pass("Emit"))]
            boxes = {ob.name: screen_box(scene, ob, bb) for ob, bb in ((a, smoke_bb), (b, smoke_bb), (c, fire_bb))}
            print("screen boxes:", boxes)
            for name, box in boxes.items():
                inside = [alpha[i] for i in range(w * h) if in_box(i, box)]
                check(sum(1 for x in inside if x > 0.05) > 20,
                      "%s: alpha in its screen region (%d pixels above 0.05, max %.3f)"
                      % (name, sum(1 for x in inside if x > 0.05), max(inside or [0])))
            outside = [i for i in range(w * h) if not any(in_box(i, bx) for bx in boxes.values())]
            outside_set = set(outside)
            check(len(outside) > 0.3 * w * h and max(alpha[i] for i in outside) == 0.0,
                  "alpha 0 outside the three regions, where the four left out stand (%d pixels, max %g)"
                  % (len(outside), max([alpha[i] for i in outside] or [0])))
            for ob in (d, e, f, g):
                bb = screen_box(scene, ob, smoke_bb, margin=0)
                px = [alpha[i] for i in range(w * h) if in_box(i, bb) and i in outside_set]
                check(len(px) > 10 and max(px) == 0.0, "%s is not rendered (%d pixels of its region)" % (ob.name, len(px)))
            ce = [emit[i] for i in range(w * h) if in_box(i, boxes["C fire"])]
            ab = [emit[i] for i in range(w * h) if in_box(i, boxes["A smoke"]) or in_box(i, boxes["B smoke"])]
            check(max(ce) > 0.0 and max(ab) == 0.0,
                  "emission in the fire's region only (fire max %.3g, smokes max %.3g)" % (max(ce), max(ab)))
            # the same picture as `vsd render` of the export
            ref, rw, rh = common.read_exr(cli.replace("####", "%04d" % FRAME))
            worst = max(abs(x - y) / max(1.0, abs(y)) for x, y in zip(alpha, ref.get("%s.Combined.A" % layer, [])))\
                if (rw, rh) == (w, h) else 1.0
            check(worst < 1e-5, "F12 equals `vsd render` of the export (alpha max rel diff %.3g)" % worst)
        # the viewport's preview of the four it shows, through the daemon (the worker's and the
        # timer's work by hand, as test_feedback does): with a method that renders one volume
        # it renders the fallback's picture, never an empty box; with the viewport's default
        # (which renders several since lbl learnt them) that method itself
        single = [n for n in catalog.names() if not catalog.has(n, SEVERAL)]
        viewport_default = catalog.default_for("viewport_default")
        cases = [("lbl" if "lbl" in single else single[0], catalog.viewport_fallback())] if single else []
        if viewport_default and catalog.has(viewport_default, SEVERAL):
            cases.append((viewport_default, viewport_default))
        if "crm" in catalog.names() and catalog.has("crm", SEVERAL) and viewport_default != "crm":
            # crm's default path renders several volumes (its parts): no fallback
            cases.append(("crm", "crm"))
        viewport = common.addon_module("viewport")
        for chosen, expected in cases:
            s.viewport_method = chosen
            p = viewport.Preview()
            try:
                dg = bpy.context.evaluated_depsgraph_get()
                p.scene_changed(bpy.context, dg)
                sc = json.loads(json.dumps(p.base.scene))
                sc["camera"] = mapping.build_scene(dg, camera=scene.camera, size=(32, 18)).scene["camera"]
                sc["output"]["passes"] = ["Combined"]
                p.process((("k",), sc, p.base.files(), [(32, 18, {})], p.settings, 0.0))
                res = p.result
                check(res is not None and p.error is None and len(sc["volumes"]) == 4 and
                      sc["render"].get("method") == expected,
                      "the preview of 4 volumes with %s renders with %s (%s)"
                      % (chosen, sc["render"].get("method"), p.error))
                if res is not None:
                    pimg, pw, ph = common.read_exr_bytes(res[3])
                    pa = [v for k, v in pimg.items() if k.endswith("Combined.A")]
                    check(bool(pa) and sum(1 for x in pa[0] if x > 0.05) > 0.05 * pw * ph,
                          "the preview with %s shows the volumes (%d of %d pixels with alpha)"
                          % (chosen, sum(1 for x in (pa[0] if pa else []) if x > 0.05), pw * ph))
            finally:
                p.stop()
        s.viewport_method = "reference"
    common.finish("test_volumes")


main()
