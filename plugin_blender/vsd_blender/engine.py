# The `VSD` render engine: F12 / animation renders through the daemon, HDR passes back as
# Blender render passes, and the rendered-shading viewport preview.
import os
import tempfile
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
            self.report({"ERROR"}, "vsd: %s" % e)
        except vsd_client.VsdError as e:
            if e.code == "cancelled":
                return
            self.report({"ERROR"}, _fmt_error(e, self._names))
        except Exception as e:  # never a traceback in the artist's face
            if DEBUG:
                traceback.print_exc()
            self.report({"ERROR"}, "vsd: unexpected error: %s: %s" % (type(e).__name__, e))

    def _render(self, depsgraph):
        scene = depsgraph.scene
        layer = depsgraph.view_layer
        w, h = self.resolution_x, self.resolution_y
        cam = self.camera_override or scene.camera
        m = mapping.build_scene(depsgraph, camera=cam, size=(w, h))
        for msg in m.warnings:
            self.report({"WARNING"}, "vsd: " + msg)
        settings = conn_settings()
        frame = scene.frame_current
        self.update_stats("", "vsd: connecting")
        files = [m.volume_path] + ([m.env_path] if m.env_path else [])

        def upload_progress(i, n):
            self.update_stats("", "vsd: uploading %d/%d (frame %d)" % (i + 1, n, frame))

        def job(c):
            names = connection.upload(c, files, progress=upload_progress)
            self._names = names
            sc = dict(m.scene)
            sc["volume"] = dict(sc["volume"], file=names[m.volume_path])
            if m.env_path:
                sc["environment"] = dict(sc["environment"], file=names[m.env_path])
            return c, sc

        c, sc = connection.with_retry(settings, job)
        if self.test_break():
            return
        method = sc["render"]["method"]

        def progress(stage, frac):
            self.update_progress(min(max(frac, 0.0), 1.0))
            self.update_stats("", "vsd %s: frame %d, %s %d%%" % (method, frame, stage, int(frac * 100)))

        self.update_stats("", "vsd %s: frame %d, queued" % (method, frame))
        try:
            res = c.render(sc, frame=frame, progress=progress, cancel=self.test_break)
        except vsd_client.VsdError as e:
            if e.code in ("connection", "protocol", "shutdown"):
                connection.drop()
            raise
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
        t = res.timings
        self.update_stats("", "vsd %s: frame %d done in %.2fs (render %.2fs)%s" % (
            method, frame, t.get("total", 0.0), t.get("render", 0.0),
            ", cached preparation" if res.cache.get("preparation") else ""))
        self.update_progress(1.0)
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
