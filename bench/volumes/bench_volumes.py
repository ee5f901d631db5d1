#!/usr/bin/env python3
"""Time and memory against the number of volumes (issue 30).

Two series of `vsd render` runs (reference by default, or --method lbl; CPU), each with 1, 2, 4 and 8 copies of the
smoke64 plume (frame 24, ../shared/data/smoke64):

* far:  copies 100 m apart along x; the camera sees copy 0 only. The box that holds all
        copies grows to 700 m, but each volume keeps its own sparse grid, so memory and
        load time follow the voxels, and a ray that misses a copy pays one box test for it.
* row:  copies 2.5 m apart, side by side in an orthographic view whose width grows with the
        count (160 x 180 pixels per copy), so every copy covers the same pixels: time per
        copy stays flat when the cost follows the voxels.

Peak memory is the process's maximum resident set (GNU time %M). The dense box a single
grid spanning the copies would need is printed beside it for contrast.

With lbl each copy is a part of its own (a 64^3 lighting grid over that copy: the copies'
media do not overlap, src/grids/volume_groups.h), and its lights are marched through the
other copies for their shadows.

    bench/volumes/bench_volumes.py [--vsd build/vsd] [--method reference|lbl] [--counts 1,2,4,8] [--spp 16]
                                   [--threads 2]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.environ.get("VSD_SHARED", os.path.join(ROOT, "..", "shared"))
SMOKE = os.path.join(SHARED, "data", "smoke64", "fluid_data_####.vdb")
ENV = os.path.join(SHARED, "data", "env", "sunset.exr")
VOXEL = 0.03125          # smoke64's voxel size (m)
EXTENT = (2.0, 2.0, 2.0) # its domain (m)


def scene(count, spacing, camera, width, height, spp, out, method):
    vols = [{"file": SMOKE, "grid": "density",
             "matrix": [1, 0, 0, i * spacing, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],
             "medium": {"density": 8.0, "albedo": [0.8, 0.8, 0.8]}} for i in range(count)]
    return {"version": 1, "volumes": vols, "environment": {"file": ENV},
            "camera": camera, "film": {"width": width, "height": height, "transparent": True},
            "render": {"method": method, "samples": spp, "seed": 1},
            "frames": {"start": 24, "end": 24}, "output": {"exr": out}}


def run(vsd, path, threads):
    t0 = time.time()
    p = subprocess.run(["/usr/bin/time", "-f", "maxrss_kb=%M", vsd, "render", path, "--quiet",
                        "--threads", str(threads), "--cache-dir", "none"],
                       capture_output=True, text=True)
    wall = time.time() - t0
    if p.returncode != 0:
        sys.exit(f"vsd render {path} failed:\n{p.stderr}")
    rss = int(p.stderr.rsplit("maxrss_kb=", 1)[1].split()[0]) / 1024.0
    return wall, rss


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vsd", default=os.path.join(ROOT, "build", "vsd"))
    ap.add_argument("--counts", default="1,2,4,8")
    ap.add_argument("--method", default="reference")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    counts = [int(c) for c in a.counts.split(",")]
    tmp = tempfile.mkdtemp(prefix="vsd-bench-volumes-")
    print(f"vsd {a.vsd}, {a.method}, {a.spp} spp, {a.threads} threads, smoke64 frame 24 copies")
    print()
    print("| series | volumes | box spanned (m) | dense box grid (MiB) | wall (s) | s per copy | peak RSS (MiB) |")
    print("|---|---|---|---|---|---|---|")
    for series in ("far", "row"):
        for n in counts:
            if series == "far":
                spacing = 100.0
                cam = {"position": [1.0, -3.9745, 1.8771], "look_at": [1.0, 1.0, 1.0], "up": [0, 0, 1], "fov": 0.7}
                w, h = 320, 180
            else:
                spacing = 2.5
                centre = (n - 1) * spacing / 2 + 1.0
                cam = {"type": "orthographic", "position": [centre, -10.0, 1.0], "look_at": [centre, 0.0, 1.0],
                       "up": [0, 0, 1], "ortho_scale": n * spacing}
                w, h = 160 * n, 180
            path = os.path.join(tmp, f"{series}{n}.json")
            with open(path, "w") as f:
                json.dump(scene(n, spacing, cam, w, h, a.spp, os.path.join(tmp, f"{series}{n}.exr"), a.method), f)
            wall, rss = run(a.vsd, path, a.threads)
            span = (n - 1) * spacing + EXTENT[0]
            dense = span / VOXEL * (EXTENT[1] / VOXEL) * (EXTENT[2] / VOXEL) * 4 / 2**20
            print(f"| {series} | {n} | {span:.0f} | {dense:.0f} | {wall:.2f} | {wall / n:.2f} | {rss:.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
