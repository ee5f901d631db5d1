# The `VSD` render engine: F12 / animation renders through the daemon, HDR passes back as
# Blender render passes, and the rendered-shading viewport preview.
import os
import tempfile
import time
import traceback

import bpy

from . import connection, mapping, passes, vsd_client

DEBUG = bool(os.environ.get("VSD_BLENDER_DEBUG"))


def addon_prefs(context=None):
    context = context or bpy.context
    addon = context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def conn_settings(context=None):
    return connection.Settings.from_prefs(addon_prefs(context))


def redraw_viewports():
    """Tag every 3D viewport for a redraw: Blender calls the engine's view_update and
    view_draw, and so the preview sees a change, only when a viewport redraws."""
    wm = getattr(bpy.context, "window_manager", None)
    for win in (wm.windows if wm is not None else []):
        for area in win.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


@bpy.app.handlers.persistent
def frame_changed(scene, depsgraph=None):
    """frame_change_post: a frame set by a script, a driver or a timer sends no redraw of
    its own, and the rendered viewport kept the old frame's preview (seen in
    test_viewport under load: no preview in 60 s); the timeline's own changes redraw anyway."""
    if scene.render.engine == VSDRenderEngine.bl_idname:
        redraw_viewports()


def _fmt_error(e, names=None):
    """The daemon's message for a report, with blob names turned back into file names."""
    if isinstance(e, vsd_client.VsdError):
        if e.code == "connection":
            return "vsd: %s" % e.message
        msg = e.message
        for path, blob in (names or {}).items():
            msg = msg.replace(blob, os.path.basename(path))
        return "vsd daemon: %s (%s)" % (msg, e.code)
    return "vsd: %s" % e


# ---- what the render window shows --------------------------------------------------------
#
# During an F12 render Blender's render header shows "Frame | Time | Mem | <info>", the info
# being the last update_stats() text. When the render ends, Blender draws the header once
# more with no info at all (do_render_full_pipeline's last stats_draw), so a "done" text
# given to update_stats() is never seen: the artist saw the last progress line ("encode 0%")
# until then and nothing of vsd after. What Blender does keep is the render result's message
# (RenderEngine.error_set(), "displayed after the render is finished", shown in the same
# header when there is no info), so the engine sets the done line there as well.

# The ETA needs a rate: none before the stage has run this long.
ETA_MIN_ELAPSED = 1.0
# Stages the daemon reports only at their start: a word instead of "0%".
STAGE_WORDS = {"start": "starting", "load": "loading the volume", "encode": "encoding the passes"}


def fmt_duration(seconds):
    s = max(0, int(round(seconds)))
    if s < 60:
        return "%d s" % s
    if s < 3600:
        return "%d min %02d s" % (s // 60, s % 60)
    return "%d h %02d min" % (s // 3600, (s % 3600) // 60)


def eta_seconds(fraction, elapsed):
    """Seconds still to go in a stage that is `fraction` done after `elapsed` seconds, at its
    rate so far; None while there is no rate to go by."""
    if fraction <= 0.0 or elapsed < ETA_MIN_ELAPSED:
        return None
    if fraction >= 1.0:
        return 0.0
    return elapsed * (1.0 - fraction) / fraction


def count_warnings(n):
    return "%d warning%s" % (n, "" if n == 1 else "s")


def warning_summary(warnings, limit=240):
    """'2 warnings: a; b', cut to about `limit` characters (Blender's header holds 512)."""
    warnings = [w for w in warnings if w]
    if not warnings:
        return ""
    text = "%s: %s" % (count_warnings(len(warnings)), "; ".join(warnings))
    return text if len(text) <= limit else text[:limit - 1] + "\u2026"


class Feedback(object):
    """The stats line and the progress bar of one F12 frame, from the daemon's PROGRESS
    messages: the stage and its percentage, the time left in it once it has a rate
    (eta_seconds; counted down between messages by tick(), which the wait for the result
    calls about ten times a second), and the mapping's warnings. stats(text) and
    progress(fraction) are the engine's update_stats / update_progress."""

    def __init__(self, stats, progress, method, frame, warnings=(), clock=time.monotonic):
        self.stats, self.progress, self.clock = stats, progress, clock
        self.method, self.frame = method, frame
        self.warnings = list(warnings)
        self.stage = None
        self.t_stage = self.t_eta = self.t_shown = 0.0
        self.fraction = 0.0
        self.eta = None
        self.lines = []   # every line shown, for the tests

    def head(self):
        return "vsd %s: frame %d" % (self.method, self.frame)

    def tail(self):
        return " \u2014 " + count_warnings(len(self.warnings)) if self.warnings else ""

    def show(self, what):
        text = "%s, %s%s" % (self.head(), what, self.tail())
        self.lines.append(text)
        self.t_shown = self.clock()
        self.stats(text)

    def on_progress(self, stage, fraction):
        now = self.clock()
        fraction = min(max(float(fraction), 0.0), 1.0)
        if stage != self.stage:
            self.stage, self.t_stage = stage, now
        self.fraction = fraction
        self.eta, self.t_eta = eta_seconds(fraction, now - self.t_stage), now
        if fraction > 0.0 or stage not in STAGE_WORDS:
            # the bar keeps its place through start, load and encode (reported at 0 only)
            self.progress(fraction)
        self._show_stage(now)

    def tick(self):
        now = self.clock()
        if self.stage is not None and now - self.t_shown >= 1.0:
            self._show_stage(now)

    def _show_stage(self, now):
        stage, f = self.stage, self.fraction
        if f <= 0.0 and stage in STAGE_WORDS:
            what = STAGE_WORDS[stage]
        else:
            what = "%s %d%%" % (stage, int(f * 100))
        if 0.0 < f < 1.0 and self.eta is not None:
            what += ", %s left" % fmt_duration(max(0.0, self.eta - (now - self.t_eta)))
        self.show(what)

    def done_line(self, timings, cached, more_warnings=()):
        for w in more_warnings:
            if w and w not in self.warnings:
                self.warnings.append(w)
        text = "%s done in %.2f s (render %.2f s%s)" % (
            self.head(), timings.get("total", 0.0), timings.get("render", 0.0),
            ", cached preparation" if cached else "")
        summary = warning_summary(self.warnings)
        if summary:
            text += " \u2014 " + summary
        self.lines.append(text)
        return text


def daemon_warnings(res):
    """The RESULT's `warnings` (a string, present only when there are any) as a list."""
    w = res.info.get("warnings") if res is not None else None
    if not w:
        return []
    if isinstance(w, (list, tuple)):
        return ["vsd daemon: %s" % x for x in w if x]
    return ["vsd daemon: %s" % w]


class VSDRenderEngine(bpy.types.RenderEngine):
    bl_idname = "VSD"
    bl_label = "vsd"
    bl_use_preview = False          # material previews need a volume preview scene
    bl_use_postprocess = True       # compositor and sequencer run on our passes
    bl_use_shading_nodes_custom = False  # Blender's shader nodes (Principled Volume)
    bl_use_eevee_viewport = True    # Material Preview shading uses EEVEE

    # From 4.4 Blender passes arguments to the engine's constructor and requires the
    # parent's __init__ to run (else the engine cannot be created and every F12 fails);
    # 3.4-4.3 pass none, and the call is harmless there.
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.preview = None

    def __del__(self):
        # Blender may free the engine's RNA before Python collects it: reading an attribute
        # then raises ReferenceError, and the preview has been stopped with the engine.
        try:
            p = self.preview
        except (AttributeError, ReferenceError):
            p = None
        if p is not None:
            p.stop()
        parent = getattr(super(), "__del__", None)
        if parent is not None:
            parent()

    # -- passes ----------------------------------------------------------------------------
    def update_render_passes(self, scene=None, renderlayer=None):
        for name, channels, chanid, ptype in passes.registered_passes(bpy.app.version):
            self.register_pass(scene, renderlayer, name, channels, chanid, ptype)

    # -- F12 / animation -------------------------------------------------------------------
    def render(self, depsgraph):
        self._names = {}
        try:
            self._render(depsgraph)
        except mapping.MappingError as e:
            self._error("vsd: %s" % e)
        except vsd_client.VsdError as e:
            if e.code == "cancelled":
                self._keep("vsd: cancelled")
                return
            self._error(_fmt_error(e, self._names))
        except Exception as e:  # never a traceback in the artist's face
            if DEBUG:
                traceback.print_exc()
            self._error("vsd: unexpected error: %s: %s" % (type(e).__name__, e))

    # What an F12 render tells the artist goes through these four (the tests wrap them).
    def _stats(self, text):
        self.update_stats("", text)

    def _progress(self, fraction):
        self.update_progress(fraction)

    def _report(self, kind, msg):
        self.report({kind}, msg)

    def _keep(self, text):
        """The line the render header keeps once the render has finished (see above);
        False where Blender would not take it (the report and the stats remain)."""
        try:
            self.error_set(text)
        except Exception:
            return False
        return True

    def _error(self, msg):
        self._report("ERROR", msg)
        self._keep(msg)

    def _render(self, depsgraph):
        scene = depsgraph.scene
        layer = depsgraph.view_layer
        w, h = self.resolution_x, self.resolution_y
        cam = self.camera_override or scene.camera
        m = mapping.build_scene(depsgraph, camera=cam, size=(w, h))
        for msg in m.warnings:
            self._report("WARNING", "vsd: " + msg)
        settings = conn_settings()
        frame = scene.frame_current
        fb = Feedback(self._stats, self._progress, m.scene["render"].get("method", "(default)"), frame,
                      m.warnings)
        self._stats("vsd: connecting" + fb.tail())
        # each volume's current frame (one blob per distinct content) and the map
        files = m.files()

        def upload_progress(i, n):
            self._stats("vsd: uploading %d/%d (frame %d)%s" % (i + 1, n, frame, fb.tail()))

        def job(c):
            names = connection.upload(c, files, progress=upload_progress)
            self._names = names
            return c, m.with_blobs(names)

        c, sc = connection.with_retry(settings, job)
        if self.test_break():
            return

        def cancel():
            fb.tick()
            return self.test_break()

        fb.show("queued")
        try:
            res = c.render(sc, frame=frame, progress=fb.on_progress, cancel=cancel)
        except vsd_client.VsdError as e:
            if e.code in ("connection", "protocol", "shutdown"):
                connection.drop()
            raise
        fb.stage = None     # no more countdown
        fb.show("loading the passes")
        fd, path = tempfile.mkstemp(prefix="vsd_frame_", suffix=".exr")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(res.exr)
            result = self.begin_result(0, 0, w, h, layer=layer.name)
            try:
                result.load_from_file(path)
            finally:
                self.end_result(result)
        finally:
            try:
                os.remove(path)
            except OSError:
                pass
        warned = daemon_warnings(res)
        for msg in warned:
            self._report("WARNING", msg)
        done = fb.done_line(res.timings, res.cache.get("preparation"), warned)
        self._progress(1.0)
        self._stats(done)
        self._keep(done)
        try:
            connection.refresh_status(settings)
        except Exception:
            pass

    # -- viewport --------------------------------------------------------------------------
    def view_update(self, context, depsgraph):
        if self.preview is None:
            from .viewport import Preview
            self.preview = Preview()
        self.preview.scene_changed(context, depsgraph)

    def view_draw(self, context, depsgraph):
        if self.preview is None:
            from .viewport import Preview
            self.preview = Preview()
            self.preview.scene_changed(context, depsgraph)
        self.preview.draw(self, context, depsgraph)
