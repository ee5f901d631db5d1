# Rendered shading in the 3D viewport (view_update / view_draw).
#
# view_update() re-maps the scene (volume frame, material, world) whenever Blender reports
# a change; view_draw() derives the vsd camera from the viewport's view and window matrices.
# Any change of either starts a new request for a worker thread, which renders first at
# 1/N of the region's resolution, then at full resolution, cancelling (CANCEL) whatever is
# superseded (a change of view skips the first pass where it would not come sooner:
# Preview.first_pass_pays). The daemon keeps the per-frame preparation of its renderer, so
# orbiting the view only re-runs the view pass (RESULT cache.preparation is true). Each
# full-resolution image's time from the change to the screen is
# connection.status["preview_latency"], shown in the Viewport panel; the scene mapping's
# warnings are drawn over the preview (yellow, an error red) and listed in the panel.
#
# Results come back as multilayer EXR with only the Combined pass. Blender's image loader
# gives no pixels for multilayer files, so the header's channel names are rewritten from
# "<layer>.Combined.R" to "R" (same sorted order, so the pixel data is untouched; only the
# line offset table moves by the header's change in size), and the file is loaded as a
# plain float image whose GPU texture is drawn through Blender's display transform.
import json
import math
import os
import struct
import tempfile
import threading
import time

import weakref

import blf
import bpy
import gpu
from gpu_extras.presets import draw_texture_2d

from . import colour, connection, mapping, method_catalog, vsd_client
from .engine import redraw_viewports

LOG = bool(os.environ.get("VSD_PREVIEW_LOG"))
MAX_DRAWN_WARNINGS = 4    # lines of warnings drawn over the preview; the panel lists all
# A view change runs the 1/N-resolution first pass only while it costs less than this share
# of the full pass (Preview.first_pass_pays).
FIRST_PASS_SHARE = 0.5
POLL_BUSY, POLL_IDLE = 0.01, 0.05   # seconds between looks for a finished result (_poll)


def single_layer_exr(data):
    """Rename '<layer>.<pass>.<chan>' channels to '<chan>' in a scanline EXR (bytes)."""
    assert data[:4] == b"\x76\x2f\x31\x01"
    pos = 8
    attrs = []
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end]
        end2 = data.index(b"\0", end + 1)
        typ = data[end + 1:end2]
        size = struct.unpack_from("<i", data, end2 + 1)[0]
        val = data[end2 + 5:end2 + 5 + size]
        attrs.append((name, typ, val))
        pos = end2 + 5 + size
    header_end = pos + 1
    out_attrs = []
    lines = 1
    height = 0
    for name, typ, val in attrs:
        if name == b"channels":
            p, chans = 0, b""
            while val[p] != 0:
                end = val.index(b"\0", p)
                cname = val[p:end].rsplit(b".", 1)[-1]
                chans += cname + b"\0" + val[end + 1:end + 17]
                p = end + 17
            val = chans + b"\0"
        elif name == b"compression":
            lines = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 16, 8: 32, 9: 256}.get(val[0], 1)
        elif name == b"dataWindow":
            _, ymin, _, ymax = struct.unpack("<4i", val)
            height = ymax - ymin + 1
        out_attrs.append((name, typ, val))
    head = bytearray(data[:8])
    for name, typ, val in out_attrs:
        head += name + b"\0" + typ + b"\0" + struct.pack("<i", len(val)) + val
    head += b"\0"
    delta = len(head) - header_end
    n = (height + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % n, data, header_end)
    head += struct.pack("<%dQ" % n, *[o + delta for o in offsets])
    return bytes(head) + data[header_end + 8 * n:]


def view_camera(context):
    """vsd camera dict of the viewport's view."""
    rv3d = context.region_data
    space = context.space_data
    cam2world = rv3d.view_matrix.inverted()
    wm = rv3d.window_matrix
    cam = {"matrix": [float(cam2world[r][c]) for r in range(4) for c in range(4)]}
    if rv3d.is_perspective:
        t = max(1.0 / wm[0][0], 1.0 / wm[1][1])
        cam["fov"] = float(min(2.0 * math.atan(t), 3.1))
        cam["clip_start"] = float(space.clip_start)
        cam["clip_end"] = float(max(space.clip_end, space.clip_start * 1.001))
    else:
        cam["type"] = "orthographic"
        cam["ortho_scale"] = float(max(2.0 / wm[0][0], 2.0 / wm[1][1]))
        cam["clip_start"] = 0.001
        cam["clip_end"] = float(max(space.clip_end, 1.0))
        # an orthographic view's eye sits in the middle of the scene: back it off
        m = cam2world.copy()
        back = m.col[2].xyz.normalized() * (space.clip_end * 0.5)
        m.translation = m.translation + back
        cam["matrix"] = [float(m[r][c]) for r in range(4) for c in range(4)]
    return cam


def _worker(wr):
    """The preview's render thread; holds its Preview only weakly so the preview (and the
    thread) end when the engine drops it."""
    while True:
        p = wr()
        if p is None or not p.alive:
            return
        with p.lock:
            if p.request is None:
                p.lock.wait(0.5)
            req, p.request = p.request, None
        if req is not None:
            p.process(req)
        del p


def _poll(wr):
    """Main-thread timer: turn finished results into images (ID writes are not allowed in
    view_draw) and redraw the viewports."""
    p = wr()
    if p is None or not p.alive:
        return None
    p.load_result()
    # while a request waits or renders, look again soon: the result's wait for this timer
    # is part of every update's time to the screen (0.025 s on average at 0.05 s)
    return POLL_BUSY if p.busy() else POLL_IDLE


class Preview(object):
    def __init__(self):
        self.alive = True
        self.lock = threading.Condition()
        self.base = None          # Mapping of the scene (no camera)
        self.error = None
        self.gen = 0
        self.key = None
        self.request = None       # (key, scene dict, files, [(w, h, options over the scene's)], settings, time)
        self.result = None        # (key, w, h, exr bytes, final, time of the request, warnings)
        self.images = []          # loaded results; the last one is drawn
        self.image_info = {}      # image name -> (final, time of the request, key)
        self.daemon_warnings = [] # the last RESULT's warnings
        self.pass_times = {}      # method -> {"low": s, "full": s}, passes with cached preparation
        self.drawn = None
        self.texture = None
        self.settings = None
        self.rendering = False    # the worker is in process() (read by the poll timer only)
        wr = weakref.ref(self)
        threading.Thread(target=_worker, args=(wr,), name="vsd-preview", daemon=True).start()
        bpy.app.timers.register(lambda: _poll(wr), first_interval=0.05)

    def stop(self):
        with self.lock:
            self.alive = False
            self.lock.notify_all()
        self.texture = None
        for img in self.images:
            try:
                bpy.data.images.remove(img)
            except Exception:
                pass
        self.images = []
        self.image_info = {}

    # -- main thread ---------------------------------------------------------------------
    def scene_changed(self, context, depsgraph):
        try:
            base = mapping.build_scene(depsgraph, viewport=True, size=(8, 8))
            err = None
        except mapping.MappingError as e:
            base, err = None, str(e)
        # Blender calls view_update for any change (the preview's own images included):
        # only a change of what vsd renders starts a new request.
        sig = json.dumps(base.scene, sort_keys=True) if base else err
        from .engine import conn_settings
        self.settings = conn_settings(context)
        if sig != getattr(self, "sig", None):
            self.sig = sig
            self.base, self.error = base, err
            self.gen += 1
            # the new request is made in view_draw: a change that Blender does not redraw for
            # by itself (a frame set from a script or timer) would otherwise wait for the next
            # unrelated redraw (seen once under load in test_viewport: no preview in 60 s)
            redraw_viewports()
        elif base is not None:
            self.base = base    # the same scene, its warnings may differ (an area light removed)
        connection.status["preview_warnings"] = self.warnings()

    def warnings(self):
        """What the artist should know about the preview: the scene mapping's warnings (a
        volume left out, the method shown instead of one that renders a single volume, a
        setting vsd cannot map, ...) and the daemon's for the last
        result, each once."""
        out = ["vsd: " + w for w in (self.base.warnings if self.base is not None else [])]
        for w in self.daemon_warnings:
            if w not in out:
                out.append(w)
        return out

    def overlay_lines(self):
        """The text drawn over the preview, bottom line first: the error (red), then the
        warnings (yellow), as (text, rgba)."""
        lines = []
        if self.error:
            lines.append((self.error, (1.0, 0.4, 0.3, 1.0)))
        warns = self.warnings()
        if warns:
            for w in reversed(warns[:MAX_DRAWN_WARNINGS]):
                lines.append((w, (1.0, 0.85, 0.3, 1.0)))
            if len(warns) > MAX_DRAWN_WARNINGS:
                lines.append(("vsd: %d more warnings (Render Properties > vsd > Viewport)"
                              % (len(warns) - MAX_DRAWN_WARNINGS), (1.0, 0.85, 0.3, 1.0)))
        return lines

    def draw(self, engine, context, depsgraph):
        region = context.region
        scene = depsgraph.scene
        w, h = region.width, region.height
        if self.base is not None:
            cam = view_camera(context)
            key = (json.dumps(cam, sort_keys=True), w, h, self.gen)
            if key != self.key:
                view_only = self.key is not None and self.key[1:] == key[1:]
                self.key = key
                sc = json.loads(json.dumps(self.base.scene))
                sc["camera"] = cam
                sc["output"]["passes"] = ["Combined"]
                files = self.base.files()
                pct = scene.vsd.viewport_resolution / 100.0
                fw, fh = max(1, int(w * pct)), max(1, int(h * pct))
                start = max(1, scene.vsd.viewport_start_scale)
                method = sc["render"]["method"]
                first = start > 1 and not (view_only and not self.first_pass_pays(method))
                # a changed scene (a material edit, a new frame) waits for its lighting, not
                # for its pixels: its first pass also takes the method's quick lighting
                # (lbl: half the cells, an eighth of the work), kept by the daemon as a
                # renderer of its own beside the full one
                quick = {} if view_only else method_catalog.preview_options(method)
                sizes = [(max(1, fw // start), max(1, fh // start), quick)] if first else []
                sizes.append((fw, fh, {}))
                with self.lock:
                    self.request = (key, sc, files, sizes, self.settings, time.monotonic())
                    self.lock.notify_all()
        new = None
        if self.images and self.drawn is not self.images[-1]:
            try:
                self.texture = gpu.texture.from_image(self.images[-1])
                self.drawn = new = self.images[-1]
            except Exception as e:
                self.error = "vsd preview: %s" % e
        if self.texture is not None:
            gpu.state.blend_set("ALPHA_PREMULT")
            engine.bind_display_space_shader(scene)
            draw_texture_2d(self.texture, (0, 0), w, h)
            engine.unbind_display_space_shader()
            gpu.state.blend_set("NONE")
        for i, (text, rgba) in enumerate(self.overlay_lines()):
            blf.position(0, 12, 12 + 20 * i, 0)
            blf.size(0, 14)
            blf.color(0, *rgba)
            blf.draw(0, text)
        connection.status["preview_error"] = self.error
        connection.status["preview_warnings"] = self.warnings()
        if new is not None:
            final, t_req, key = self.image_info.get(new.name, (False, None, None))
            if final and t_req is not None and key == self.key:
                # from the change of view (or scene) to its full-resolution image on screen
                connection.status["preview_latency"] = time.monotonic() - t_req
                connection.status["preview_image"] = new.name
            elif t_req is not None and key == self.key:
                # the same to its first, 1/N-resolution image (when that pass ran)
                connection.status["preview_first_latency"] = time.monotonic() - t_req

    def first_pass_pays(self, method):
        """Whether the 1/N-resolution pass puts an image on screen sooner after a change of
        view. Not for a method whose view pass has a cost that does not shrink with the
        pixels: a method that evaluates every light record toward the camera once per view
        took 0.29 s for its 66x41 pass against 0.34 s at 264x166 (issue 28), so the two
        passes took 0.63 s where the full one alone takes 0.34 s. Measured on this preview's last passes with cached
        preparation (a scene change keeps the first pass: it pays the preparation, and then
        shows the new scene sooner)."""
        t = self.pass_times.get(method, {})
        low, full = t.get("low"), t.get("full")
        return low is None or full is None or low < FIRST_PASS_SHARE * full

    def load_result(self):
        with self.lock:
            res, self.result = self.result, None
        if res is None:
            return
        key, rw, rh, exr, final, t_req, warns = res
        self.daemon_warnings = warns
        fd, path = tempfile.mkstemp(prefix="vsd_preview_", suffix=".exr")
        with os.fdopen(fd, "wb") as f:
            f.write(single_layer_exr(exr))
        try:
            img = bpy.data.images.load(path, check_existing=False)
            img.name = ".vsd_preview"
            # the result is in Blender's working space ("Linear" in 3.4, "Linear Rec.709"
            # from 4.0, the file's choice from 5.0): a name the version lacks raised here
            # and dropped the poll timer, leaving the viewport blank
            img.colorspace_settings.name = colour.image_space_for_results()
            img.alpha_mode = "PREMUL"
            img.pixels[0]  # read the file now; it is removed below
        finally:
            try:
                os.remove(path)
            except OSError:
                pass
        self.images.append(img)
        self.image_info[img.name] = (final, t_req, key)
        # keep the one being drawn until the new one is on screen
        while len(self.images) > 2:
            old = self.images.pop(0)
            self.image_info.pop(old.name, None)
            bpy.data.images.remove(old)
        redraw_viewports()

    # -- worker thread -------------------------------------------------------------------
    def _superseded(self):
        with self.lock:
            return (not self.alive) or self.request is not None

    def busy(self):
        """A request waits, the worker renders one, or a result waits to be loaded."""
        return self.rendering or self.request is not None or self.result is not None

    def process(self, req):
        key, sc, files, sizes, settings, t_req = req
        self.rendering = True
        try:
            self._render(key, sc, files, sizes, settings, t_req)
            self.error = None
        except vsd_client.VsdError as e:
            if e.code != "cancelled":
                self.error = "vsd: %s" % e.message
                connection.drop()
                time.sleep(0.5)
        except Exception as e:  # keep the worker alive
            self.error = "vsd preview: %s" % e
            time.sleep(0.5)
        finally:
            self.rendering = False

    def _render(self, key, sc, files, sizes, settings, t_req):
        c = connection.client(settings)
        names = connection.upload(c, files)
        sc = mapping.with_blobs(sc, names)
        options = dict(sc["render"].get("options", {}))
        for i, (w, h, quick) in enumerate(sizes):
            if self._superseded():
                return
            final = i == len(sizes) - 1
            sc["film"]["width"], sc["film"]["height"] = w, h
            if options or quick:
                sc["render"]["options"] = dict(options, **quick)
            else:
                sc["render"].pop("options", None)   # the full pass: not the quick one's
            if i == 0:   # what the tests check: the quick options on the first pass only
                connection.status["preview_quick"] = dict(quick)
            if final:
                connection.status["preview_final_options"] = dict(sc["render"].get("options", {}))
            t0 = time.monotonic()
            res = c.render(sc, frame=sc["frames"]["start"], cancel=self._superseded)
            t1 = time.monotonic()
            if res.cache.get("preparation") and not quick:
                self.pass_times.setdefault(sc["render"]["method"], {})["full" if final else "low"] = t1 - t0
            warns = res.info.get("warnings")
            warns = ["vsd daemon: %s" % warns] if isinstance(warns, str) and warns else []
            with self.lock:
                if not self.alive:
                    return
                self.result = (key, w, h, res.exr, final, t_req, warns)
            if final:
                connection.status["preview_fps"] = 1.0 / max(1e-6, t1 - t0)
                connection.status["preview_prepared"] = bool(res.cache.get("preparation"))
            if LOG:
                print("vsd preview: %dx%d in %.3fs (%.1f fps, %s%s, preparation %s)%s" % (
                    w, h, t1 - t0, 1.0 / max(1e-6, t1 - t0), sc["render"]["method"],
                    (" quick %s" % json.dumps(quick, sort_keys=True) if quick else ""),
                    "cached" if res.cache.get("preparation") else "new",
                    " final, %.3fs after the change" % (t1 - t_req) if final else ""), flush=True)
