# What differs between the Blenders the add-on runs in (issue 28): 3.4 (Debian's binary) and
# 4.2 LTS, 4.5 LTS, 5.0 (PyPI's bpy wheels, through tests/blender_addon/blender_wheel.py).
#   blender -b --factory-startup --python-exit-code 1 --python test_versions.py -- VSD DATA TMP
#
# Each part names the finding it guards and the version where it failed before its fix:
#  1. F12 creates the engine (4.4+ pass arguments to RenderEngine.__init__; failed in 4.5, 5.0).
#  2. The viewport's result poll tags its image with the working space (3.4's "Linear" does
#     not exist from 4.0: the poll raised and the viewport stayed blank; failed in 4.2+).
#  3. The pass names of F12 are the ones this version's own Cycles writes (Combined,
#     VolumeDir/VolumeInd/Emit or 5.0's "Volume Direct"/"Volume Indirect"/"Emission",
#     Depth): the file and the Render Layers node's sockets, rendered with Cycles here.
#  5. Colour: a map tagged "Linear Rec.2020" is converted to Rec.709 (it was sent as if it
#     were Rec.709: failed everywhere), one tagged ACEScg renders (the daemon's config
#     lacked the name: failed in 4.2+), and 5.0's per-file working space is honoured (the
#     map is converted to it; failed in 5.0).
#  6. Building the scene reads no deprecated property (Material/World.use_nodes: 5.0).
#  7. 4.5's light Exposure, Normalize and Temperature reach vsd as Cycles applies them
#     (checked against this version's Cycles); 5.0's CUSTOM camera is a warning.
import math
import os
import time
import sys
import warnings

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402
import mathutils  # noqa: E402

VERSION = tuple(bpy.app.version)

# Rec.2020 -> Rec.709 (linear, D65), ITU-R BT.2087's inverse
REC2020_TO_REC709 = ((1.6605, -0.5876, -0.0728), (-0.1246, 1.1329, -0.0083), (-0.0182, -0.1006, 1.1187))
# ACES AP1 (ACEScg) -> Rec.709 (linear, Bradford from D60 to D65), as published by the ACES project
ACESCG_TO_REC709 = ((1.70505, -0.62179, -0.08326), (-0.13026, 1.14080, -0.01055), (-0.02400, -0.12897, 1.15297))


def image_space_names():
    prop = bpy.types.ColorManagedInputColorspaceSettings.bl_rna.properties["name"]
    return [i.identifier for i in prop.enum_items]


def expected_working_space():
    """Blender's working space, as this test knows it independently of the add-on: 5.0's
    per-file setting, else the config's scene_linear ("Linear Rec.709" from 4.0, "Linear")."""
    cs = getattr(bpy.data, "colorspace", None)
    if cs is not None and getattr(cs, "working_space", ""):
        return cs.working_space
    return "Linear Rec.709" if "Linear Rec.709" in image_space_names() else "Linear"


def close_rgb(a, b, rel=2e-3):
    """Equal within `rel` (0.2 %: the published matrices' 4-5 digits and the render's float)."""
    return all(abs(x - y) <= rel * max(1.0, abs(y)) + 1e-4 for x, y in zip(a, b))


def mat3(m, v):
    return [sum(m[r][c] * v[c] for c in range(3)) for r in range(3)]


def f12(tmp, name):
    out = os.path.join(tmp, name + ".exr")
    err = common.run_blender_render(out)
    img = common.read_exr(out)[0] if err is None and os.path.exists(out) else {}
    return err, img


def channel(img, layer, pass_name, c):
    return img.get("%s.%s.%s" % (layer, pass_name, c))


def background_mean(img, layer, names):
    """Mean Combined RGB over the pixels no view ray hit density in (Depth empty)."""
    dep = channel(img, layer, names["Depth"], "Z")
    rgb = [channel(img, layer, "Combined", c) for c in "RGB"]
    idx = [i for i, z in enumerate(dep) if z >= 1e9]
    return [sum(ch[i] for i in idx) / max(1, len(idx)) for ch in rgb], len(idx)


def background_render(tmp, name, layer, names):
    """F12 -> (error, mean background RGB, pixel count) of the render saved as NAME."""
    err, img = f12(tmp, name)
    if err is not None:
        return err, [0.0, 0.0, 0.0], 0
    bg, n = background_mean(img, layer, names)
    return None, bg, n


def cycles_passes(tmp, scene):
    """The pass names in the multilayer EXR this version's Cycles writes for the scene, with
    the passes vsd fills enabled (1 sample: only the names matter)."""
    saved = (scene.render.engine, scene.render.film_transparent)
    layer = scene.view_layers[0]
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False   # Debian's 3.4 is built without OpenImageDenoise
    layer.use_pass_combined = True
    layer.use_pass_z = True
    layer.use_pass_emit = True
    layer.cycles.use_pass_volume_direct = True
    layer.cycles.use_pass_volume_indirect = True
    tree = common.compositor_tree(scene)
    rl = tree.nodes.new("CompositorNodeRLayers")
    sockets = [s.name for s in rl.outputs if s.enabled]
    tree.nodes.remove(rl)
    err, img = f12(tmp, "cycles_names")
    scene.render.engine, scene.render.film_transparent = saved
    names = sorted({k.split(".")[1] for k in img if k.count(".") >= 2})
    return err, names, sockets


def plane_under_light(kind, **props):
    """Mean linear RGB of a white diffuse plane 2 m under a light, by this version's Cycles
    (64 samples, 12x12 pixels of an orthographic view of 0.2 m): for light unit checks."""
    scene = bpy.data.scenes.new("lightcheck")
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 64
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = 12
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    mesh = bpy.data.meshes.new("plane")
    mesh.from_pydata([(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], [], [(0, 1, 2, 3)])
    plane = bpy.data.objects.new("plane", mesh)
    scene.collection.objects.link(plane)
    cam = bpy.data.cameras.new("ortho")
    cam.type = "ORTHO"
    cam.ortho_scale = 0.2
    cob = bpy.data.objects.new("ortho", cam)
    cob.location = (0, 0, 1)
    scene.collection.objects.link(cob)
    scene.camera = cob
    light = bpy.data.lights.new("probe", kind)
    for k, v in props.items():
        setattr(light, k, v)
    lob = bpy.data.objects.new("probe", light)
    lob.location = (0, 0, 2)
    scene.collection.objects.link(lob)
    window_scene = bpy.context.window.scene if bpy.context.window else None
    path = os.path.join(TMP, "plane_%s.exr" % kind)
    scene.render.filepath = path
    scene.render.use_file_extension = False
    scene.render.image_settings.file_format = "OPEN_EXR"
    bpy.ops.render.render(write_still=True, scene=scene.name)
    img, w, h = common.read_exr(path)
    mean = [sum(img[c]) / (w * h) for c in "RGB"]
    mapped = common.addon_module("mapping").map_light(light, lob.matrix_world, common.addon_module("mapping").Mapping())
    for ob in (plane, cob, lob):
        bpy.data.objects.remove(ob, do_unlink=True)
    bpy.data.scenes.remove(scene)
    if window_scene is not None:
        bpy.context.window.scene = window_scene
    return mean, mapped


TMP = None


def main():
    global TMP
    vsd, data, tmp = common.start_test()
    TMP = tmp
    mapping = common.addon_module("mapping")
    passes = common.addon_module("passes")
    names = passes.pass_names(VERSION)
    print("Blender %s: pass names %s, working space %r" % (bpy.app.version_string, names, expected_working_space()))
    with common.addon_daemon(vsd, tmp) as d:
        scene, ob = common.build_scene(data, width=48, height=27, transparent=False)
        layer = scene.view_layers[0].name

        # --- 6. no deprecated property is read while the scene is mapped --------------------
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mapping.build_scene(bpy.context.evaluated_depsgraph_get())
        dep = [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]
        check(not dep, "6. mapping the scene reads no deprecated property (%s)" % dep)

        # --- 1. F12 creates the engine and renders ------------------------------------------
        err, img = f12(tmp, "f12")
        comb = channel(img, layer, "Combined", "R")
        check(err is None and comb is not None and max(comb) > 0.0,
              "1. F12 creates the engine and renders Combined (%s)" % err)

        # --- 3. pass names equal this version's Cycles' ---------------------------------------
        cerr, cnames, csockets = cycles_passes(tmp, scene)
        vsd_names = sorted({k.split(".")[1] for k in img if k.count(".") >= 2})
        for p in ("Combined", "VolumeDir", "VolumeInd", "Emit", "Depth"):
            check(cerr is None and names[p] in cnames and names[p] in vsd_names,
                  "3. pass %s is '%s' in both this Cycles' file %s and the add-on's %s (%s)"
                  % (p, names[p], cnames, vsd_names, cerr))
            if p != "Combined":
                check(names[p] in csockets, "3. Cycles' Render Layers node offers '%s' (%s)" % (names[p], csockets))
        tree = common.compositor_tree(scene)
        rl = tree.nodes.new("CompositorNodeRLayers")
        vsockets = [s.name for s in rl.outputs if s.enabled]
        tree.nodes.remove(rl)
        for p in ("VolumeDir", "VolumeInd", "Emit", "Depth"):
            check(names[p] in vsockets, "3. the vsd engine's Render Layers node offers '%s' (%s)" % (names[p], vsockets))

        # --- 2. the viewport's result poll, called by hand -------------------------------------
        viewport = common.addon_module("viewport")
        vsd_client = common.addon_module("vsd_client")
        connection = common.addon_module("connection")
        m = mapping.build_scene(bpy.context.evaluated_depsgraph_get())
        sc = dict(m.scene)
        sc["output"] = dict(sc["output"], passes=["Combined"])
        c = connection.client(connection.Settings.from_prefs(common.addon_prefs()))
        sc = mapping.with_blobs(sc, connection.upload(c, m.files()))
        res = c.render(sc, frame=sc["frames"]["start"])
        p = viewport.Preview()
        try:
            # what the preview's worker thread hands the poll (viewport.Preview.result)
            p.result = ("key", 48, 27, res.exr, True, time.monotonic(), [])
            try:
                p.load_result()     # bpy.app.timers run this in a window; not under a wheel
                perr = None
            except Exception as e:
                perr = "%s: %s" % (type(e).__name__, e)
            loaded = p.images[-1] if p.images else None
            check(perr is None and loaded is not None, "2. the viewport's poll loads the result (%s)" % perr)
            if loaded is not None:
                check(loaded.colorspace_settings.name == expected_working_space(),
                      "2. the preview image is tagged with the working space '%s' (%s)"
                      % (expected_working_space(), loaded.colorspace_settings.name))
                px = list(loaded.pixels)
                ref = common.read_exr_bytes(res.exr)[0]
                r_ref = ref["%s.Combined.R" % layer]
                # Blender's images are stored bottom row first
                w, h = loaded.size
                top_left = px[((h - 1) * w) * 4]
                check(abs(top_left - r_ref[0]) <= 1e-5 * max(1.0, abs(r_ref[0])),
                      "2. the preview's pixels are the daemon's (%g vs %g)" % (top_left, r_ref[0]))
        finally:
            p.stop()

        # --- 5. colour spaces ------------------------------------------------------------------
        env_img = scene.world.node_tree.nodes["Environment Texture"].image
        space_names = image_space_names()
        lin709 = "Linear Rec.709" if "Linear Rec.709" in space_names else "Linear"
        env_img.colorspace_settings.name = lin709
        err, bg709, n709 = background_render(tmp, "env_709", layer, names)
        check(err is None and n709 > 0 and min(bg709) > 0, "5. background pixels with the map as %s: %s (%s)"
              % (lin709, bg709, err))
        if "Linear Rec.2020" in space_names:
            env_img.colorspace_settings.name = "Linear Rec.2020"
            sent = mapping.build_scene(bpy.context.evaluated_depsgraph_get()).scene["environment"]
            check(sent.get("colorspace") == "Linear Rec.2020" and sent.get("working_space") == expected_working_space(),
                  "5. a Rec.2020 map is sent with its space and the working space (%s)" % sent)
            err, bg2020, _ = background_render(tmp, "env_2020", layer, names)
            want = mat3(REC2020_TO_REC709, bg709)
            check(err is None and close_rgb(bg2020, want),
                  "5. the Rec.2020 map's background = the Rec.709 one through BT.2020->709 (%s vs %s; %s)"
                  % (bg2020, want, err))
        if "ACEScg" in space_names or "Linear ACEScg" in space_names:
            env_img.colorspace_settings.name = "ACEScg" if "ACEScg" in space_names else "Linear ACEScg"
            err, bgcg, _ = background_render(tmp, "env_acescg", layer, names)
            want = mat3(ACESCG_TO_REC709, bg709)
            # 0.5 %: Blender 3.4's config reaches ACEScg by its own matrix, not OCIO's builtin
            check(err is None and close_rgb(bgcg, want, 5e-3),
                  "5. an ACEScg map's background = the Rec.709 one through AP1->709 (%s vs %s; %s)"
                  % (bgcg, want, err))
        env_img.colorspace_settings.name = lin709
        cs = getattr(bpy.data, "colorspace", None)
        if cs is not None and hasattr(cs, "working_space"):
            # 5.0: the blend file renders in Rec.2020; the Rec.709 map is converted to it.
            # Changing the working space converts the file's colours; the map's tag stays.
            # (read-only in RNA: the operator sets it; no conversion of the file's colours, so
            # the scene stays the same numbers, now meant in Rec.2020)
            bpy.ops.wm.set_working_color_space(working_space="Linear Rec.2020", convert_colors=False)
            env_img.colorspace_settings.name = "Linear Rec.709"
            sent = mapping.build_scene(bpy.context.evaluated_depsgraph_get()).scene["environment"]
            check(sent.get("colorspace") == "Linear Rec.709" and sent.get("working_space") == "Linear Rec.2020",
                  "5. 5.0's working space Rec.2020: the map goes from Rec.709 to it (%s)" % sent)
            err, bgws, _ = background_render(tmp, "env_ws2020", layer, names)
            back = mat3(REC2020_TO_REC709, bgws)
            check(err is None and close_rgb(back, bg709),
                  "5. rendered in Rec.2020: its background, taken back to Rec.709, equals the Rec.709 "
                  "render's (%s vs %s; %s)" % (back, bg709, err))
            bpy.ops.wm.set_working_color_space(working_space="Linear Rec.709", convert_colors=False)
            env_img.colorspace_settings.name = "Linear Rec.709"
        else:
            print("note: 5.0's per-file working space does not exist in %s" % bpy.app.version_string)

        # --- 7. lights: 4.5's Exposure, Normalize, Temperature; 5.0's CUSTOM camera -------------
        if "exposure" in bpy.types.Light.bl_rna.properties.keys():
            base_px, base_map = plane_under_light("POINT", energy=1000.0, shadow_soft_size=0.2)
            for what, props in (("exposure 1", {"exposure": 1.0}),
                                ("normalize off, radius 0.1", {"normalize": False, "shadow_soft_size": 0.1}),
                                ("exposure -1.5, normalize off, radius 0.4",
                                 {"exposure": -1.5, "normalize": False, "shadow_soft_size": 0.4})):
                kw = dict(energy=1000.0, shadow_soft_size=0.2)
                kw.update(props)
                px, pmap = plane_under_light("POINT", **kw)
                # against the same light with exposure 0 and normalize on: only the factor differs
                bpx, bmap = plane_under_light("POINT", energy=1000.0, shadow_soft_size=kw["shadow_soft_size"])
                want = sum(px) / sum(bpx)
                got = pmap["power"] / bmap["power"]
                check(abs(got / want - 1.0) < 0.03,
                      "7. %s: power x %.4f sent, Cycles renders x %.4f" % (what, got, want))
            sun_px, sun_map = plane_under_light("SUN", energy=3.0, angle=0.1)
            sun2_px, sun2_map = plane_under_light("SUN", energy=3.0, angle=0.1, normalize=False)
            want = sum(sun2_px) / sum(sun_px)
            got = sun2_map["strength"] / sun_map["strength"]
            check(abs(got / want - 1.0) < 0.03, "7. sun with normalize off: x %.5f sent, Cycles x %.5f" % (got, want))
            for kelvin in (3000.0, 5000.0, 9000.0):
                t_px, t_map = plane_under_light("POINT", energy=1000.0, shadow_soft_size=0.2, use_temperature=True,
                                                temperature=kelvin)
                want = [t_px[i] / base_px[i] for i in range(3)]
                got = t_map["color"]
                check(all(abs(g - w) <= 0.02 * w + 0.01 for g, w in zip(got, want)),
                      "7. temperature %g K: colour %s sent, Cycles renders x %s" % (kelvin, [round(x, 4) for x in got],
                                                                                 [round(x, 4) for x in want]))
        else:
            print("note: Light.exposure/normalize/use_temperature do not exist in %s" % bpy.app.version_string)
        cam_types = [i.identifier for i in bpy.types.Camera.bl_rna.properties["type"].enum_items]
        if "CUSTOM" in cam_types:
            scene.camera.data.type = "CUSTOM"
            m = mapping.build_scene(bpy.context.evaluated_depsgraph_get())
            check(any("CUSTOM" in w and "perspective" in w for w in m.warnings),
                  "7. a CUSTOM camera is a warning (%s)" % m.warnings)
            scene.camera.data.type = "PERSP"
        else:
            print("note: no CUSTOM camera type in %s" % bpy.app.version_string)
    common.finish("test_versions")


main()
