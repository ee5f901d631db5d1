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
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
os.environ["VSD_PREVIEW_LOG"] = "1"
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402
import mathutils  # noqa: E402

state = {"step": 0, "t0": time.monotonic(), "results": 0}
vsd, data, tmp, rest = common.args()
docs = rest[rest.index("--docs") + 1] if "--docs" in rest else None


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


# (what changes, how, the file the new preview must upload, or None). Scene frame 1 shows
# fluid_data_0020.vdb (frame offset 19), so frame 2 needs fluid_data_0021.vdb, which the
# daemon has not seen yet.
CHANGES = [
    ("material: Principled Volume Density 8 -> 4", lambda: _set_density(4.0), None),
    ("frame +1", lambda: bpy.context.scene.frame_set(bpy.context.scene.frame_current + 1),
     os.path.join("smoke64", "fluid_data_0021.vdb")),
    ("world: Background Strength -> 0.6", lambda: _set_strength(0.6), None),
]


def apply_change(i):
    conn = state["connection"]
    conn.status["preview_fps"] = None
    conn.status["preview_prepared"] = None
    state["bytes0"] = common.vsd_stats(state["daemon"].sock)["blob_bytes_received"]
    CHANGES[i][1]()


def orbit(view3d, degrees):
    """Turn the (non-camera) view about Z by `degrees`, as dragging the middle mouse does,
    and forget the last preview so the next one is the new view's."""
    rv3d = view3d.spaces.active.region_3d
    state["yaw"] = state.get("yaw", 20.0) + degrees
    rv3d.view_rotation = mathutils.Euler((math.radians(75), 0, math.radians(state["yaw"])), "XYZ").to_quaternion()
    view3d.tag_redraw()
    conn = state["connection"]
    conn.status["preview_fps"] = None
    conn.status["preview_prepared"] = None


def setup():
    common.fresh_tmp(tmp)
    common.install_addon(tmp, vsd=vsd)
    state["daemon"] = d = common.Daemon(vsd, tmp)
    prefs = common.addon_prefs()
    prefs.address = d.sock
    if docs:  # a fuller plume, the studio's lamp out of frame, a sharper preview
        scene, ob = common.build_scene(data, width=640, height=360, frame_start=1, frame_offset=29,
                                       rotation_deg=150.0, strength=1.5)
        scene.view_settings.view_transform = "Filmic"
        scene.vsd_options.raymarch.lights = 8
        scene.vsd_options.raymarch.pixel_samples = 1
        scene.vsd.viewport_resolution = 25
    else:
        scene, ob = common.build_scene(data, width=640, height=360, frame_start=1, frame_offset=19)
        scene.vsd_options.raymarch.lights = 4
        scene.vsd_options.raymarch.pixel_samples = 1
        scene.vsd.viewport_resolution = 25
    scene.vsd.viewport_method = "raymarch"
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
        if st.get("preview_fps"):
            state["bench"].append((st["preview_fps"], st.get("preview_prepared")))
            if len(state["bench"]) < BENCH_STEPS:
                orbit(view3d, 10.0)
                state["t0"] = time.monotonic()
                return 0.25
            fps = sorted(f for f, _ in state["bench"])
            w = max(1, region.width * bpy.context.scene.vsd.viewport_resolution // 100)
            h = max(1, region.height * bpy.context.scene.vsd.viewport_resolution // 100)
            print("preview benchmark: %d orbit steps, %dx%d preview (%s, %d lights): full-resolution "
                  "preview %.2f frames/s median, %.2f min, %.2f max" % (
                      len(fps), w, h, bpy.context.scene.vsd.viewport_method,
                      bpy.context.scene.vsd_options.raymarch.lights, fps[len(fps) // 2], fps[0], fps[-1]), flush=True)
            check(all(p is True for _, p in state["bench"]),
                  "every orbit step re-used the daemon's preparation (%s)" % [p for _, p in state["bench"]])
            state.update(step=7, t0=time.monotonic(), change=0)
            apply_change(0)
            return 0.25
        if el > 60:
            check(False, "orbit step %d of the preview benchmark was re-rendered" % (len(state["bench"]) + 1))
            return finish()
        return 0.25
    if s == 7:  # material, frame and world changes each start a new preview
        label, _, new_file = CHANGES[state["change"]]
        if st.get("preview_fps"):
            check(True, "%s: a new preview" % label)
            if new_file:
                sent = common.vsd_stats(state["daemon"].sock)["blob_bytes_received"] - state["bytes0"]
                want = os.path.getsize(os.path.join(data, new_file))
                check(sent == want, "%s: the preview sent %s (%d bytes, expected %d)" % (label, new_file, sent, want))
            state["change"] += 1
            if state["change"] < len(CHANGES):
                apply_change(state["change"])
                state["t0"] = time.monotonic()
                return 0.25
            state.update(step=4, t0=time.monotonic())
            return 0.5
        if el > 60:
            check(False, "%s: the viewport preview was re-rendered" % label)
            return finish()
        return 0.25
    if s == 4:
        shot = os.path.join(tmp, "window2.png")
        screenshot(shot)
        check(os.path.isfile(shot), "window screenshot after orbit")
        if docs:
            make_docs(view3d, props)
        return finish()
    return None


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
