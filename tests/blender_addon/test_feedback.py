# What the artist is told during and after a render (issue 28, B-D), in real Blender:
#
# * the render header's countdown (engine.Feedback, no daemon): the time left in a stage is
#   its elapsed time times (1 - f) / f once it has run a second, and it counts down between
#   the daemon's PROGRESS messages;
# * raymarch, the slow baseline, is marked so in the method menu (its label and tooltip);
# * F12 with raymarch through a daemon: the progress bar's fractions never fall within the
#   ray-marching stage and reach 1, the stats lines show its percentage with the time left
#   ("N%, T left"), and the first estimate made at a quarter of the stage or later is within
#   3x of the time the stage then took (the tiles are handed out spread over the image, so the
#   fraction done follows the work done: cpu_tiles.h);
# * after the render the last stats line says "done in", and the engine has given the same
#   line to RenderEngine.error_set(): Blender's header is redrawn without the engine's info
#   when a render ends, and shows that message instead (engine.py, "what the render window
#   shows"), so an artist no longer sees "encode 0%" or nothing;
# * the scene mapping's warnings (an area light, which vsd does not render): a WARNING report
#   each, "1 warning" on every stats line during the render, and the warning's text in the
#   done line Blender keeps after the render;
# * the viewport preview, driven by hand (its timer never fires under the bpy module): the
#   warning is in Preview.warnings(), drawn in yellow by overlay_lines(), and in the panel's
#   connection.status["preview_warnings"]; removing the light clears it; a preview rendered
#   through the daemon (Preview.process, then load_result as its timer would) loads its
#   image and remembers when it was requested, for the time-to-screen it reports; a change of
#   view skips the 1/N-resolution first pass where it costs as much as the full one (lbl).
#
# Usage: blender -b --factory-startup --python-exit-code 1 --python test_feedback.py -- VSD DATA TMP
# (also under the bpy wheels, through tests/blender_addon/blender_wheel.py).
import json
import os
import re
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402

LEFT = re.compile(r"ray marching (\d+)%, (?:(\d+) h (\d+) min|(\d+) min (\d+) s|(\d+) s) left")


def left_seconds(m):
    if m.group(2):
        return int(m.group(2)) * 3600 + int(m.group(3)) * 60
    if m.group(4):
        return int(m.group(4)) * 60 + int(m.group(5))
    return int(m.group(6))


class Recorder(object):
    """Wraps the engine's four outputs (_stats -> update_stats, _progress -> update_progress,
    _keep -> error_set, _report -> report) on its class, so every call of a render is logged
    with its time and still reaches Blender."""
    NAMES = ("_stats", "_progress", "_keep", "_report")

    def __init__(self, cls):
        self.cls, self.log = cls, []
        self.orig = {name: getattr(cls, name) for name in self.NAMES}
        for name in self.NAMES:
            setattr(cls, name, self._wrap(name, getattr(cls, name)))

    def _wrap(self, name, orig):
        log = self.log

        def fn(engine, *a):
            ret = orig(engine, *a)
            log.append((time.monotonic(), name, a, ret))
            return ret
        return fn

    def calls(self, name):
        return [(t, a) for t, n, a, _ in self.log if n == name]

    def kept(self):
        """The texts given to error_set, and whether Blender took each."""
        return [(a[0], ret) for _, n, a, ret in self.log if n == "_keep"]

    def remove(self):
        for name in self.NAMES:
            setattr(self.cls, name, self.orig[name])


def unit_checks(engine):
    check(engine.eta_seconds(0.25, 10.0) == 30.0 and engine.eta_seconds(0.5, 0.5) is None and
          engine.eta_seconds(0.0, 50.0) is None, "eta_seconds: elapsed x (1 - f) / f once a second has passed")
    check((engine.fmt_duration(7.4), engine.fmt_duration(125), engine.fmt_duration(9720)) ==
          ("7 s", "2 min 05 s", "2 h 42 min"), "durations read as an artist reads them")
    now = [100.0]
    shown, bar = [], []
    fb = engine.Feedback(shown.append, bar.append, "raymarch", 3, ["light 'A': area lights are not supported"],
                         clock=lambda: now[0])
    fb.on_progress("ray marching", 0.0)
    now[0] = 110.0
    fb.on_progress("ray marching", 0.5)
    check(shown[-1] == "vsd raymarch: frame 3, ray marching 50%, 10 s left \u2014 1 warning",
          "half way after 10 s: 10 s left, and the warning count (%r)" % shown[-1])
    now[0] = 114.0
    fb.tick()
    check(shown[-1].startswith("vsd raymarch: frame 3, ray marching 50%, 6 s left"),
          "the estimate counts down between messages (%r)" % shown[-1])
    n = len(shown)
    now[0] = 114.5
    fb.tick()
    check(len(shown) == n, "at most one countdown line a second")
    fb.on_progress("encode", 0.0)
    check("encoding the passes" in shown[-1] and "0%" not in shown[-1], "encode reads as a word (%r)" % shown[-1])
    check(bar == [0.0, 0.5], "the progress bar gets each fraction, and keeps its place at encode (%s)" % bar)
    done = fb.done_line({"total": 2.5, "render": 2.0}, False, ["vsd daemon: values above 4"])
    check(done.startswith("vsd raymarch: frame 3 done in 2.50 s (render 2.00 s)") and
          "2 warnings: light 'A': area lights are not supported; vsd daemon: values above 4" in done,
          "the done line carries the mapping's and the daemon's warnings (%r)" % done)


def main():
    vsd, data, tmp = common.start_test()
    engine = common.addon_module("engine")
    connection = common.addon_module("connection")
    unit_checks(engine)

    catalog = common.addon_module("method_catalog")
    item = [m for m in catalog.menu_items(None, None) if m[0] == "raymarch"][0]
    check("slow baseline" in item[1] and "baseline" in item[2] and "hours" in item[2],
          "raymarch is marked the slow baseline in the method menu (%r)" % (item[1],))

    d = common.Daemon(vsd, tmp)
    rec = Recorder(engine.VSDRenderEngine)
    try:
        common.addon_prefs().address = d.sock
        scene, ob = common.build_scene(data, width=160, height=90, frame_start=1, frame_offset=19)
        # raymarch at its default step, with enough lights for a render of several seconds
        scene.vsd_options.raymarch.lights = 64
        # --- B and C: progress, time left, done ---------------------------------------------
        t0 = time.monotonic()
        err = common.run_blender_render(os.path.join(tmp, "raymarch.exr"))
        t_end = time.monotonic()
        check(err is None, "F12 with raymarch (%s, %.1f s)" % (err, t_end - t0))
        stats = [(t, a[0]) for t, a in rec.calls("_stats")]
        for t, line in stats:
            print("  %6.2f s  %s" % (t - t0, line))
        march = [(t, line) for t, line in stats if "ray marching" in line]
        pct = [int(re.search(r"ray marching (\d+)%", line).group(1)) for _, line in march]
        check(len(set(pct)) >= 4 and pct == sorted(pct),
              "the stats show the ray marching advance, never back (%s)" % pct)
        prog = [a[0] for _, a in rec.calls("_progress")]
        t_first = march[0][0] if march else t0
        in_stage = [a[0] for t, a in rec.calls("_progress") if march and t >= t_first and t <= march[-1][0]]
        check(in_stage == sorted(in_stage) and len(set(in_stage)) >= 4,
              "update_progress fractions increase through the stage (%s)" % ["%.3f" % f for f in in_stage])
        check(prog and prog[-1] == 1.0, "the progress bar ends at 1 (%s)" % prog[-1:])
        lefts = [(t, int(m.group(1)), left_seconds(m)) for t, line in march for m in [LEFT.search(line)] if m]
        check(len(lefts) >= 2, "the stats show the time left in the stage (%d lines)" % len(lefts))
        t_stage_end = ([t for t, line in stats if "encoding" in line or "loading the passes" in line] or [t_end])[0]
        later = [x for x in lefts if x[1] >= 25]
        if later:
            t, p, est = later[0]
            actual = t_stage_end - t
            check(actual / 3.0 - 1.0 <= est <= actual * 3.0 + 1.0,
                  "the estimate at %d%% (%d s left) is within 3x of the time the stage still took (%.1f s)"
                  % (p, est, actual))
        else:
            check(False, "an estimate at a quarter of the stage or later")
        last = stats[-1][1]
        check("done in" in last and "encode" not in last, "the last stats line says done (%r)" % last)
        kept = rec.kept()
        check(kept and kept[-1] == (last, True),
              "the done line is what Blender keeps in the header after the render (%s)" % (kept[-1:],))
        # --- D: the mapping's warnings at F12 -----------------------------------------------
        del rec.log[:]
        scene.vsd_options.raymarch.lights = 8
        light = bpy.data.lights.new("Panel", "AREA")
        lob = bpy.data.objects.new("Panel", light)
        scene.collection.objects.link(lob)
        lob.location = (1.0, -2.0, 3.0)
        err = common.run_blender_render()
        check(err is None, "F12 with an area light (%s)" % err)
        warn = "light 'Panel': area lights are not supported: ignored"
        reports = [a for _, a in rec.calls("_report")]
        check(any("WARNING" in a[0] and warn in a[1] for a in reports), "a WARNING report (%s)" % reports)
        stats = [a[0] for _, a in rec.calls("_stats")]
        during = [s for s in stats if "done in" not in s]
        check(during and all(s.endswith("\u2014 1 warning") for s in during),
              "every stats line during the render says 1 warning (%s)" % during)
        last = stats[-1]
        kept = rec.kept()
        check("done in" in last and "1 warning: " + warn in last and kept and kept[-1] == (last, True),
              "the done line Blender keeps names the warning (%r)" % last)
        # --- D: the viewport preview --------------------------------------------------------
        viewport = common.addon_module("viewport")
        mapping = common.addon_module("mapping")
        p = viewport.Preview()
        try:
            dg = bpy.context.evaluated_depsgraph_get()
            p.scene_changed(bpy.context, dg)
            check(p.warnings() == ["vsd: " + warn], "the preview knows the mapping's warning (%s)" % p.warnings())
            lines = p.overlay_lines()
            check(("vsd: " + warn, (1.0, 0.85, 0.3, 1.0)) in lines,
                  "the warning is drawn over the preview in yellow (%s)" % lines)
            check(connection.status.get("preview_warnings") == ["vsd: " + warn],
                  "the Viewport panel lists it (%s)" % connection.status.get("preview_warnings"))
            p.error = "vsd: daemon gone"
            check(p.overlay_lines()[0] == ("vsd: daemon gone", (1.0, 0.4, 0.3, 1.0)),
                  "an error is the bottom line, in red, the warnings above it")
            p.error = None
            p.pass_times = {"lbl": {"low": 0.29, "full": 0.34}, "crm": {"low": 0.02, "full": 0.10}}
            check(not p.first_pass_pays("lbl") and p.first_pass_pays("crm") and p.first_pass_pays("shgrid"),
                  "a view change skips the 1/N first pass where it costs half the full one or more (lbl)")
            p.pass_times = {}
            bpy.data.objects.remove(lob, do_unlink=True)
            dg = bpy.context.evaluated_depsgraph_get()
            p.scene_changed(bpy.context, dg)
            check(p.warnings() == [] and p.overlay_lines() == [] and connection.status["preview_warnings"] == [],
                  "no warning once the light is gone (%s)" % p.warnings())
            # a preview through the daemon, the worker's and the timer's work by hand
            cam = mapping.build_scene(dg, camera=scene.camera, size=(32, 18)).scene["camera"]
            sc = json.loads(json.dumps(p.base.scene))   # as Preview.draw builds a request
            sc["camera"] = cam
            sc["output"]["passes"] = ["Combined"]
            files = p.base.files()
            t_req = time.monotonic()
            p.process((("k",), sc, files, [(32, 18, {})], p.settings, t_req))
            check(p.result is not None and p.error is None, "the preview rendered (%s)" % p.error)
            p.load_result()
            img = p.images[-1] if p.images else None
            check(img is not None and tuple(img.size) == (32, 18) and p.image_info.get(img.name) == (True, t_req, ("k",)),
                  "its image is loaded, final, with the time of its request (%s)" % (p.image_info,))
        finally:
            p.stop()
    finally:
        rec.remove()
        rc = d.stop()
    check(rc == 0, "daemon exits 0 on SIGTERM")
    common.finish("test_feedback")


main()
