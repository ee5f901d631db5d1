# The rendered viewport preview in a real Blender window (Xvfb, software OpenGL):
#
#   xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup --python-exit-code 1 \
#       --python tests/blender_addon/test_viewport.py -- VSD DATA TMP [--docs DOCS_DIR]
#
# A bpy.app.timers callback drives the UI: it switches the 3D viewport to Rendered shading,
# waits for the preview's low-resolution and full-resolution images, orbits the view and
# checks that the daemon re-used its cached preparation (only the view pass ran), runs the
# preview benchmark (BENCH_STEPS further orbit steps: the full-resolution preview's frames
# per second, printed as "preview benchmark: ..."), checks that a material, a frame and a
# world change each start a new preview (the frame change uploads the next .vdb), takes a
# screenshot of the window (viewport + the vsd render panel) and checks the viewport shows
# the smoke. With --docs it also writes docs/blender-panel.png and docs/blender-render.png.
#
# The viewport shows what F12 will show (issue 28): the preview runs the add-on's default
# viewport method (the catalog's viewport_default), which must have multiple scattering, and
# with a transparent film the mean Combined of its full-resolution image is within
# BRIGHTNESS_TOL of an F12 render with `reference` from the same view, size and scene (a
# camera made from the viewport's view). The same check run on shgrid's preview (single
# scattering only) must fail it: shgrid's smoke is about half as bright. The benchmark
# times each orbit step from the view change to its full-resolution image on screen
# (connection.status["preview_latency"], set when the preview draws it) and prints "seconds
# per update". A mapping warning (an area light) is drawn over the preview in yellow.
# --viewport-method NAME runs all of it with another viewport method (to measure it); a
# single-scattering one must then fail the brightness check instead.
import math
import os
import sys
import time
import types

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
os.environ["VSD_PREVIEW_LOG"] = "1"
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402
import mathutils  # noqa: E402

state = {"step": 0, "t0": time.monotonic(), "results": 0}
vsd, data, tmp, rest = common.args()
docs = rest[rest.index("--docs") + 1] if "--docs" in rest else None
# scene frame 1 shows smoke64 file FRAME_OFFSET + 1; the frame change shows the next file, so
# the docs' fuller plume starts at file 29, not 30 (the sequence ends at 30: a frame past it
# clips to the same file and nothing would change)
FRAME_OFFSET = 28 if docs else 19
method_arg = rest[rest.index("--viewport-method") + 1] if "--viewport-method" in rest else None
# |mean Combined of the preview / F12 reference - 1|. Measured here (issue 28): lbl 1.003,
# crm 1.031, shgrid 0.508; `vsd render` of this scene's F12 view at 264x166 against 4096 spp:
# lbl 1.005, crm 1.007, shgrid 0.484.
BRIGHTNESS_TOL = 0.10


def single_scattering(method):
    """Whether vsd says the method scatters light once only (its catalog's capabilities)."""
    return not common.addon_module("method_catalog").has(method, "multiple_scattering")


def window_parts():
    win = bpy.context.window_manager.windows[0]
    screen = win.screen
    view3d = max((a for a in screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    region = [r for r in view3d.regions if r.type == "WINDOW"][0]
    props = [a for a in screen.areas if a.type == "PROPERTIES"]
    return win, screen, view3d, region, props


def screenshot(path, area=None):
    win, screen, view3d, region, _ = window_parts()
    kw = {"window": win, "screen": screen}
    if area is not None:
        kw.update(area=area, region=[r for r in area.regions if r.type == "WINDOW"][0])
        with bpy.context.temp_override(**kw):
            bpy.ops.screen.screenshot_area(filepath=path)
    else:
        with bpy.context.temp_override(**kw):
            bpy.ops.screen.screenshot(filepath=path)


def region_stats(png, area):
    """Mean and spread of the luminance inside the 3D viewport's part of a window shot."""
    img = bpy.data.images.load(png, check_existing=False)
    w, h = img.size
    px = list(img.pixels)
    bpy.data.images.remove(img)
    vals = []
    for y in range(area.y + 20, area.y + area.height - 20, 4):
        for x in range(area.x + 20, area.x + area.width - 20, 4):
            if 0 <= x < w and 0 <= y < h:
                i = (y * w + x) * 4
                vals.append(0.3 * px[i] + 0.6 * px[i + 1] + 0.1 * px[i + 2])
    mean = sum(vals) / max(1, len(vals))
    spread = max(vals) - min(vals) if vals else 0.0
    return mean, spread


BENCH_STEPS = 6


def _set_density(v):
    bpy.data.materials["smoke_mat"].node_tree.nodes["Principled Volume"].inputs["Density"].default_value = v


def _set_strength(v):
    bpy.context.scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = v


# (what changes, how, the file the new preview must upload, or None, whether it changes the
# lighting: then its first pass takes the method's preview_options). Scene frame 1 shows
# fluid_data_0020.vdb (frame offset 19), so frame 2 needs fluid_data_0021.vdb, which the
# daemon has not seen yet.
CHANGES = [
    ("material: Principled Volume Density 8 -> 4", lambda: _set_density(4.0), None, True),
    ("frame +1", lambda: bpy.context.scene.frame_set(bpy.context.scene.frame_current + 1),
     lambda: os.path.join("smoke64", "fluid_data_%04d.vdb" % (FRAME_OFFSET + 2)), True),
    ("world: Background Strength -> 0.6", lambda: _set_strength(0.6), None, False),
]


def apply_change(i):
    """Make change i and forget the last preview. The mean colour of the image on screen
    before the change is remembered: the add-on sets status["preview_image"] only when it
    draws a full-resolution image of its current request (viewport.py: image_info's key ==
    the view's key), and that image must differ from the one before (every change here
    changes the picture; a stale preview would not)."""
    conn = state["connection"]
    name = conn.status.get("preview_image")
    # the preview reuses one image: its content, not its name, tells a new picture
    state["mean_before"] = image_mean_rgb(bpy.data.images[name]) if name in bpy.data.images else None
    forget_preview()
    state["bytes0"] = common.vsd_stats(state["daemon"].sock)["blob_bytes_received"]
    CHANGES[i][1]()


def orbit(view3d, degrees):
    """Turn the (non-camera) view about Z by `degrees`, as dragging the middle mouse does,
    and forget the last preview so the next one is the new view's."""
    rv3d = view3d.spaces.active.region_3d
    state["yaw"] = state.get("yaw", 20.0) + degrees
    rv3d.view_rotation = mathutils.Euler((math.radians(75), 0, math.radians(state["yaw"])), "XYZ").to_quaternion()
    view3d.tag_redraw()
    forget_preview()


def forget_preview():
    """Forget the last preview, so that the next one seen is the new view's or scene's."""
    st = state["connection"].status
    for k in ("preview_fps", "preview_prepared", "preview_latency", "preview_first_latency", "preview_image",
              "preview_quick", "preview_final_options"):
        st[k] = None


def preview_ready(st):
    """The new full-resolution preview is on screen (drawn, not only rendered)."""
    return bool(st.get("preview_fps") and st.get("preview_latency") and st.get("preview_image"))


def image_mean_rgb(img):
    px = img.pixels[:]
    n = len(px) // 4
    return sum(px[i] + px[i + 1] + px[i + 2] for i in range(0, 4 * n, 4)) / (3.0 * n)


def exr_mean_rgb(path, layer="ViewLayer"):
    ch, w, h = common.read_exr(path)
    vals = [ch["%s.Combined.%s" % (layer, c)] for c in "RGB"]
    return sum(sum(v) for v in vals) / (3.0 * w * h)


def camera_from_view(view3d):
    """A Blender camera that sees what the viewport's preview renders: the add-on's own
    view_camera() of the view (perspective, fov across the larger side), as a camera object
    with Sensor Fit Auto (the mapping's fov across the larger side)."""
    space = view3d.spaces.active
    vcam = common.addon_module("viewport").view_camera(types.SimpleNamespace(region_data=space.region_3d,
                                                                             space_data=space))
    data = bpy.data.cameras.get("vp_cam") or bpy.data.cameras.new("vp_cam")
    data.sensor_fit = "AUTO"
    data.sensor_width = 36.0
    data.lens = 18.0 / math.tan(vcam["fov"] / 2.0)
    data.clip_start, data.clip_end = vcam["clip_start"], vcam["clip_end"]
    ob = bpy.data.objects.get("vp_cam") or bpy.data.objects.new("vp_cam", data)
    if ob.name not in bpy.context.scene.collection.objects:
        bpy.context.scene.collection.objects.link(ob)
    m = vcam["matrix"]
    ob.matrix_world = mathutils.Matrix([m[4 * r:4 * r + 4] for r in range(4)])
    return ob


def warning_pixels(png, region):
    """Pixels of the warning's yellow in the band the preview draws its text lines in."""
    img = bpy.data.images.load(png, check_existing=False)
    w, h = img.size
    px = img.pixels[:]
    bpy.data.images.remove(img)
    n = 0
    for y in range(region.y + 6, min(h, region.y + 100)):
        for x in range(region.x + 6, min(w, region.x + 700)):
            i = (y * w + x) * 4
            r, g, b = px[i], px[i + 1], px[i + 2]
            # blf's (1, 0.85, 0.3) reaches the screen through the display transform as
            # about (1, 0.9, 0.6); anti-aliased edges are darker
            if r > 0.8 and g > 0.6 and b < 0.7 and r - b > 0.25:
                n += 1
    return n


def setup():
    common.fresh_tmp(tmp)
    common.install_addon(tmp, vsd=vsd)
    state["daemon"] = d = common.Daemon(vsd, tmp)
    prefs = common.addon_prefs()
    prefs.address = d.sock
    if docs:  # a fuller plume, the studio's lamp out of frame, a sharper preview
        scene, ob = common.build_scene(data, width=640, height=360, frame_start=1, frame_offset=FRAME_OFFSET,
                                       rotation_deg=150.0, strength=1.5)
        scene.view_settings.view_transform = "Filmic"
        scene.vsd_options.raymarch.lights = 8
        scene.vsd_options.raymarch.pixel_samples = 1
        scene.vsd.viewport_resolution = 25
    else:
        scene, ob = common.build_scene(data, width=640, height=360, frame_start=1, frame_offset=FRAME_OFFSET)
        scene.vsd_options.raymarch.lights = 4
        scene.vsd_options.raymarch.pixel_samples = 1
        scene.vsd.viewport_resolution = 25
    catalog = common.addon_module("method_catalog")
    default = scene.vsd.viewport_method
    check(default == catalog.default_for("viewport_default") and not single_scattering(default),
          "the viewport's default method has multiple scattering (%s)" % default)
    if method_arg:
        scene.vsd.viewport_method = method_arg
    state["method"] = scene.vsd.viewport_method
    scene.vsd.viewport_start_scale = 4
    scene.vsd.method = "raymarch"
    scene.render.film_transparent = False
    # reopening the saved file closes the splash screen (--factory-startup shows it)
    blend = os.path.join(tmp, "viewport.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    state["connection"] = common.addon_module("connection")


def step():
    try:
        return _step()
    except Exception:
        import traceback
        traceback.print_exc()
        os._exit(1)


def _step():
    conn = state["connection"] if "connection" in state else None
    s = state["step"]
    el = time.monotonic() - state["t0"]
    if s == 0:
        setup()
        state.update(step=5, t0=time.monotonic())
        return 0.5
    if s == 5:  # after the reload: the viewport of the reopened file
        win, screen, view3d, region, props = window_parts()
        space = view3d.spaces.active
        space.shading.type = "RENDERED"
        space.overlay.show_overlays = False
        space.region_3d.view_perspective = "CAMERA"
        for a in props:
            a.spaces.active.context = "RENDER"
        bpy.ops.vsd.daemon_status()
        state.update(step=1, t0=time.monotonic())
        return 0.5
    win, screen, view3d, region, props = window_parts()
    st = conn.status
    if s == 1:  # wait for the first full-resolution preview
        if st.get("preview_fps"):
            state["fps1"] = st["preview_fps"]
            state.update(step=2, t0=time.monotonic())
            return 1.0
        if el > 90:
            check(False, "the viewport preview produced a full-resolution image (%s)" % st)
            return finish()
        return 0.25
    if s == 2:
        check(True, "first preview at full resolution: %.2f frames/s" % state["fps1"])
        shot = os.path.join(tmp, "window1.png")
        screenshot(shot)
        mean, spread = region_stats(shot, view3d)
        check(spread > 0.2, "the viewport shows the rendered smoke and environment (spread %.2f)" % spread)
        # orbit: leave the camera view and turn 20 degrees about Z
        rv3d = view3d.spaces.active.region_3d
        rv3d.view_perspective = "PERSP"
        rv3d.view_location = mathutils.Vector((1.0, 1.0, 1.0))
        rv3d.view_distance = 5.0
        rv3d.view_rotation = mathutils.Euler((math.radians(75), 0, math.radians(20)), "XYZ").to_quaternion()
        view3d.tag_redraw()
        st["preview_fps"] = None
        st["preview_prepared"] = None
        state.update(step=3, t0=time.monotonic())
        return 0.25
    if s == 3:
        if st.get("preview_fps"):
            check(st.get("preview_prepared") is True,
                  "orbiting re-uses the daemon's preparation (cache.preparation %s)" % st.get("preview_prepared"))
            check(True, "orbit preview: %.2f frames/s" % st["preview_fps"])
            state.update(step=6, t0=time.monotonic(), bench=[], yaw=20.0)
            orbit(view3d, 10.0)
            return 0.25
        if el > 60:
            check(False, "the orbited view was re-rendered")
            return finish()
        return 0.25
    if s == 6:  # the preview benchmark: BENCH_STEPS orbit steps of 10 degrees, one preview each
        if preview_ready(st):
            state["bench"].append((st["preview_fps"], st.get("preview_prepared"), st["preview_latency"]))
            if st.get("preview_first_latency") is not None:
                state.setdefault("bench_first", []).append(st["preview_first_latency"])
            if len(state["bench"]) < BENCH_STEPS:
                orbit(view3d, 10.0)
                state["t0"] = time.monotonic()
                return 0.25
            fps = sorted(f for f, _, _ in state["bench"])
            lat = sorted(t for _, _, t in state["bench"])
            w = max(1, region.width * bpy.context.scene.vsd.viewport_resolution // 100)
            h = max(1, region.height * bpy.context.scene.vsd.viewport_resolution // 100)
            print("preview benchmark: %d orbit steps, %dx%d preview (%s): full-resolution "
                  "preview %.2f frames/s median, %.2f min, %.2f max; seconds per update (view change to "
                  "the new image on screen) %.3f median, %.3f min, %.3f max" % (
                      len(fps), w, h, bpy.context.scene.vsd.viewport_method,
                      fps[len(fps) // 2], fps[0], fps[-1], lat[len(lat) // 2], lat[0], lat[-1]), flush=True)
            first = sorted(state.get("bench_first", []))
            print("preview benchmark: a 1/N-resolution image first on %d of %d orbit steps%s" % (
                len(first), len(fps), "; view change to it %.3f s median, %.3f max" % (
                    first[len(first) // 2], first[-1]) if first else " (none drawn before the full one: "
                "skipped where it would not come sooner, Preview.first_pass_pays, or replaced before a redraw)"),
                flush=True)
            check(all(p is True for _, p, _ in state["bench"]),
                  "every orbit step re-used the daemon's preparation (%s)" % [p for _, p, _ in state["bench"]])
            state.update(step=7, t0=time.monotonic(), change=0)
            apply_change(0)
            return 0.25
        if el > 60:
            check(False, "orbit step %d of the preview benchmark was re-rendered" % (len(state["bench"]) + 1))
            return finish()
        return 0.25
    if s == 7:  # material, frame and world changes each start a new preview
        label, _, new_file, relit = CHANGES[state["change"]]
        if preview_ready(st):
            # not check(True): preview_fps alone is also set by a render of the old request
            # still in flight (a stale preview); the drawn image must be this change's
            before = state.get("mean_before")
            after = image_mean_rgb(bpy.data.images[st["preview_image"]])
            moved = before is not None and abs(after - before) > 1e-3 * max(abs(before), 1e-9)
            check(moved, "%s: a new picture on screen (mean RGB %.6g, before the change %s)" % (label, after, before))
            want = common.addon_module("method_catalog").preview_options(state["method"])
            if relit and want:
                # the change's first pass is lit on the method's quick lighting (its
                # preview_options: lbl's half the cells), kept by the daemon beside the full one
                check(st.get("preview_quick") == want,
                      "%s: the first pass asked for the quick lighting %s (sent %s)" % (label, want, st.get("preview_quick")))
                final = st.get("preview_final_options") or {}
                check(all(final.get(k) != v for k, v in want.items()),
                      "%s: the full pass is lit in full (its options %s)" % (label, final))
            print("preview benchmark: %s: %.3f s from the change to its full-resolution image on screen%s" % (
                label, st["preview_latency"], "" if st.get("preview_first_latency") is None else
                " (%.3f s to the 1/N-resolution one)" % st["preview_first_latency"]), flush=True)
            if new_file:
                sent = common.vsd_stats(state["daemon"].sock)["blob_bytes_received"] - state["bytes0"]
                new_file = new_file()
                want = os.path.getsize(os.path.join(data, new_file))
                check(sent == want, "%s: the preview sent %s (%d bytes, expected %d)" % (label, new_file, sent, want))
            state["change"] += 1
            if state["change"] < len(CHANGES):
                apply_change(state["change"])
                state["t0"] = time.monotonic()
                return 0.25
            state.update(step=8, t0=time.monotonic(), sub=0)
            return 0.5
        if el > 60:
            check(False, "%s: the viewport preview was re-rendered" % label)
            return finish()
        return 0.25
    if s == 8:  # the preview's brightness against F12 with `reference`
        return brightness(view3d, st, el)
    if s == 9:  # a mapping warning drawn over the preview
        return warning_overlay(view3d, region, st, el)
    if s == 4:
        shot = os.path.join(tmp, "window2.png")
        screenshot(shot)
        check(os.path.isfile(shot), "window screenshot after orbit")
        if docs:
            make_docs(view3d, props)
        return finish()
    return None


def brightness(view3d, st, el):
    """Sub-steps: 0 the F12 scene back (density 8, strength 1.2) with a transparent film, so
    Combined is the smoke's light alone; 1 its preview's mean against F12 `reference` of
    the same view; 2-3 the same preview with shgrid, which must fail the check."""
    scene = bpy.context.scene
    sub = state["sub"]
    if sub in (0, 2):
        if sub == 0:
            _set_density(8.0)
            _set_strength(1.2)
            scene.render.film_transparent = True
        else:
            scene.vsd.viewport_method = "shgrid"
        forget_preview()
        state.update(sub=sub + 1, t0=time.monotonic())
        return 0.25
    if not preview_ready(st):
        if el > 90:
            check(False, "a preview with a transparent film (%s)" % scene.vsd.viewport_method)
            return finish()
        return 0.25
    method = scene.vsd.viewport_method
    img = bpy.data.images[st["preview_image"]]
    vp_mean = image_mean_rgb(img)
    if "f12" not in state:
        cam = camera_from_view(view3d)
        saved = (scene.camera, scene.render.resolution_x, scene.render.resolution_y,
                 scene.render.resolution_percentage, scene.vsd.method, scene.vsd.samples)
        scene.camera = cam
        scene.render.resolution_x, scene.render.resolution_y = img.size[0], img.size[1]
        scene.render.resolution_percentage = 100
        scene.vsd.method, scene.vsd.samples = "reference", 64
        path = os.path.join(tmp, "f12_reference.exr")
        t0 = time.monotonic()
        err = common.run_blender_render(path)
        check(err is None, "F12 with reference from the viewport's view, %dx%d, %.1f s (%s)"
              % (img.size[0], img.size[1], time.monotonic() - t0, err))
        (scene.camera, scene.render.resolution_x, scene.render.resolution_y,
         scene.render.resolution_percentage, scene.vsd.method, scene.vsd.samples) = saved
        state["f12"] = exr_mean_rgb(path) if err is None else float("nan")
    ratio = vp_mean / state["f12"] if state["f12"] > 0 else float("nan")
    print("brightness: %s preview %dx%d mean Combined %.5f, F12 reference %.5f: ratio %.3f"
          % (method, img.size[0], img.size[1], vp_mean, state["f12"], ratio), flush=True)
    if single_scattering(method):
        check(ratio < 1.0 - 2 * BRIGHTNESS_TOL,
              "%s (single scattering only) is darker than F12's reference: the check sees it (ratio %.3f)"
              % (method, ratio))
    else:
        check(abs(ratio - 1.0) <= BRIGHTNESS_TOL,
              "the %s preview is as bright as F12 with reference (mean Combined ratio %.3f, tolerance %.2f)"
              % (method, ratio, BRIGHTNESS_TOL))
    if state["sub"] == 1 and not single_scattering(method):
        state.update(sub=2, t0=time.monotonic())
        return 0.25
    scene.vsd.viewport_method = state["method"]
    scene.render.film_transparent = False
    forget_preview()
    state.update(step=9, sub=0, t0=time.monotonic())
    return 0.25


def warning_overlay(view3d, region, st, el):
    """Sub-steps: 0 a window shot without warnings; 1 an area light (vsd does not render
    them: a mapping warning); 2 its text drawn over the preview in yellow, and listed for
    the panel; then the light is removed."""
    sub = state["sub"]
    if sub == 0:
        if not preview_ready(st) and el < 60:
            return 0.25
        shot = os.path.join(tmp, "no_warning.png")
        screenshot(shot)
        state["yellow0"] = warning_pixels(shot, region)
        light = bpy.data.lights.new("Panel", "AREA")
        ob = bpy.data.objects.new("Panel", light)
        bpy.context.scene.collection.objects.link(ob)
        ob.location = (1.0, -2.0, 3.0)
        state.update(sub=1, t0=time.monotonic())
        return 0.5
    want = "vsd: light 'Panel': area lights are not supported: ignored"
    if want not in (st.get("preview_warnings") or []):
        if el > 30:
            check(False, "the preview knows the area light's warning (%s)" % st.get("preview_warnings"))
            return finish()
        view3d.tag_redraw()
        return 0.25
    bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
    shot = os.path.join(tmp, "warning.png")
    screenshot(shot)
    yellow = warning_pixels(shot, region)
    check(yellow > state["yellow0"] + 200,
          "the warning is drawn over the preview (%d yellow text pixels, %d without it)" % (yellow, state["yellow0"]))
    bpy.data.objects.remove(bpy.data.objects["Panel"], do_unlink=True)
    state.update(step=4, t0=time.monotonic())
    return 0.5


def make_docs(view3d, props):
    """docs/blender-panel.png (the window: rendered viewport + vsd panel) and
    docs/blender-render.png (an F12 frame as Blender saves it)."""
    rv3d = view3d.spaces.active.region_3d
    rv3d.view_perspective = "CAMERA"
    view3d.tag_redraw()
    conn = state["connection"]
    conn.status["preview_fps"] = None
    t0 = time.monotonic()
    while not conn.status.get("preview_fps") and time.monotonic() - t0 < 60:
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
        time.sleep(0.2)
    bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=2)
    bpy.ops.vsd.daemon_status()
    bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=2)
    screenshot(os.path.join(docs, "blender-panel.png"))
    scene = bpy.context.scene
    scene.vsd.method = "reference"
    scene.vsd.samples = 64
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_depth = "8"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.filepath = os.path.join(docs, "blender-render.png")
    bpy.ops.render.render(write_still=True)
    print("docs images written to", docs)


def finish():
    d = state.get("daemon")
    if d is not None:
        st = common.vsd_stats(d.sock)
        print("daemon STATS:", st["jobs"], st["cache"]["renderers"])
        rc = d.stop()
        check(rc == 0, "daemon exits 0")
    common.finish("test_viewport")
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(step, first_interval=1.0, persistent=True)  # survives the reload
