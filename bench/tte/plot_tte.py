#!/usr/bin/python3
"""Log-log plot of error against time from bench_tte's CSV (bench/tte/bench_tte.c).

    /usr/bin/python3 bench/tte/plot_tte.py TTE.csv OUT.png [--title TEXT]

One column per scene, rows: VolumeDir error, Combined error, each against the time of a
camera change at the timing film (for `reference`, a whole render: a path tracer caches
nothing). `reference` is a line through its sample counts (and `reference+lbl`, the path
tracer with lbl's light as its cache, a dashed one; `cycles`, Blender Cycles with the
cross-check's settings, a dotted one); every other method is one point. Printed: for each
Cycles point, the time `reference` takes to its Combined error (log-log between the two
sample counts around it) and the equal-error speed-up over Cycles (issue 33). A method earns its place where its point lies below and left of the reference
line. Needs Debian's python3-matplotlib (not installed by scripts/install-deps.sh: only
the benchmark needs it).
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MARKERS = {"raymarch": "s", "shgrid": "o", "constellation": "^", "crm": "D", "lbl": "v"}


def time_at_error(pts, err):
    """The time of a (time, error) curve at error err, log-log between the two points around
    it; None outside the measured range."""
    pts = sorted(pts)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if min(e0, e1) <= err <= max(e0, e1) and e0 != e1:
            f = math.log(err / e0) / math.log(e1 / e0)
            return math.exp(math.log(t0) + f * math.log(t1 / t0))
    return None


def curve(rows, scene, method, key):
    """(time, error, spp) of a method's measured rows on a scene (the failed or timed-out left out)."""
    return [(float(r["camera"]), float(r[key]), int(r["spp"])) for r in rows if r["scene"] == scene and r["method"] == method
            and float(r["camera"]) > 0 and float(r[key]) > 0 and not math.isnan(float(r[key]))]


def print_speedups(rows):
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for m in [m for m in dict.fromkeys(r["method"] for r in rows) if m.startswith("reference")]:
            ref = [(t, e) for t, e, _ in curve(rows, scene, m, "err_combined")]
            for t_c, e_c, spp in curve(rows, scene, "cycles", "err_combined"):
                t_r = time_at_error(ref, e_c)
                print("%s: Cycles %d spp, Combined %.2f%% in %.1f s; %s reaches it in %s: %s" % (
                    scene, spp, 100 * e_c, t_c, m, "%.1f s" % t_r if t_r else "(outside its sample counts)",
                    "%.1fx faster" % (t_c / t_r) if t_r else "n/a"))


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    title = argv[argv.index("--title") + 1] if "--title" in argv else ""
    rows = list(csv.DictReader(open(argv[1])))
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(2, len(scenes), figsize=(5.5 * len(scenes), 8.5), squeeze=False)
    for col, scene in enumerate(scenes):
        for row, (key, label) in enumerate((("err_voldir", "VolumeDir"), ("err_combined", "Combined"))):
            ax = axes[row][col]
            lines = [m for m in dict.fromkeys(r["method"] for r in rows) if m.startswith("reference") or m == "cycles"]
            for m in lines:
                pts = curve(rows, scene, m, key)
                if not pts:
                    continue
                style = {"reference": ("-", "black", "reference (path tracer)"),
                         "cycles": (":", "tab:orange", "Blender Cycles (path tracer)")}.get(
                             m, ("--", "grey", m.replace("+", " with cache ")))
                ax.plot([p[0] for p in pts], [p[1] for p in pts], style[0], color=style[1], marker=".", label=style[2])
                if m in ("reference", "cycles"):
                    for t, e, spp in pts:
                        ax.annotate("%d spp" % spp, (t, e), textcoords="offset points", xytext=(4, 4), fontsize=8)
            for r in rows:
                if r["scene"] != scene or r["method"].startswith("reference") or r["method"] == "cycles":
                    continue
                t, e = float(r["camera"]), float(r[key])
                if not (t > 0 and e > 0) or math.isnan(e):
                    continue
                ax.plot([t], [e], MARKERS.get(r["method"], "x"), markersize=9, label=r["method"])
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xlabel("camera change, seconds")
            ax.set_ylabel("%s rel. RMSE vs converged reference" % label)
            ax.set_title("%s: %s" % (scene, label))
            ax.legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(argv[2], dpi=90)
    print_speedups(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
