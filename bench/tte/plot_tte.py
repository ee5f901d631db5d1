#!/usr/bin/python3
"""Log-log plot of error against time from bench_tte's CSV (bench/tte/bench_tte.c).

    /usr/bin/python3 bench/tte/plot_tte.py TTE.csv OUT.png [--title TEXT]

One column per scene, rows: VolumeDir error, Combined error, each against the time of a
camera change at the timing film (for `reference`, a whole render: a path tracer caches
nothing). `reference` is a line through its sample counts (and `reference+lbl`, the path
tracer with lbl's light as its cache, a dashed one); every other method is one point. A method earns its place where its point lies below and left of the reference
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
            lines = [m for m in dict.fromkeys(r["method"] for r in rows) if m.startswith("reference")]
            for m in lines:
                ref = [r for r in rows if r["scene"] == scene and r["method"] == m]
                pts = [(float(r["camera"]), float(r[key]), int(r["spp"])) for r in ref
                       if float(r["camera"]) > 0 and float(r[key]) > 0 and not math.isnan(float(r[key]))]
                if not pts:
                    continue
                ax.plot([p[0] for p in pts], [p[1] for p in pts], "-" if m == "reference" else "--",
                        color="black" if m == "reference" else "grey", marker=".",
                        label="reference (path tracer)" if m == "reference" else m.replace("+", " with cache "))
                if m == "reference":
                    for t, e, spp in pts:
                        ax.annotate("%d spp" % spp, (t, e), textcoords="offset points", xytext=(4, 4), fontsize=8)
            for r in rows:
                if r["scene"] != scene or r["method"].startswith("reference"):
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
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
