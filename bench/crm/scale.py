#!/usr/bin/python3
"""bench/crm/scale.py VSD OUTDIR [--methods crm,lbl] [--width 1280 --height 720]

Issue 31 item 4: a cold frame of 8x the voxels against the original. Makes cloud256
upsampled x2 per axis (a grid of half the voxel size whose even voxels are the old voxels
and whose odd ones interpolate linearly between them: 8x the active voxels, the same
world positions and optical depth) with python3-openvdb
(Debian's python3-openvdb, run by /usr/bin/python3), writes a scene beside it, then renders
both scenes cold (no fit cache, a fresh process) with each method and prints wall time and
peak RSS (GNU time). The made volume lives in OUTDIR only; nothing is committed.
"""
import json, os, subprocess, sys, argparse
import numpy as np
import pyopenvdb as vdb

root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
shared = os.environ.get("VSD_SHARED", os.path.join(root, "..", "shared"))
ap = argparse.ArgumentParser()
ap.add_argument("vsd")
ap.add_argument("out")
ap.add_argument("--methods", default="crm")
ap.add_argument("--width", type=int, default=1280)
ap.add_argument("--height", type=int, default=720)
ap.add_argument("--set", action="append", default=[])
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)
src_scene = os.path.join(shared, "data", "scenes", "cloud256_sunset.json")
src_vdb = os.path.join(shared, "data", "cloud", "cloud256.vdb")

big_vdb = os.path.join(a.out, "cloud256_x2.vdb")
if not os.path.exists(big_vdb):
    g = vdb.read(src_vdb, "density")
    (lo, hi) = g.evalActiveVoxelBoundingBox()
    shape = tuple(h - l + 1 for l, h in zip(lo, hi))
    arr = np.zeros(shape, dtype=np.float32)
    g.copyToArray(arr, ijk=lo)
    # new voxel 2i is old voxel i (the same world point at half the voxel size), new voxel
    # 2i + 1 the midpoint between old voxels i and i + 1: linear per axis, so trilinear
    p = np.pad(arr, 1)
    def axis_up(x, ax):
        a0 = np.take(x, range(0, x.shape[ax] - 1), axis=ax)
        a1 = np.take(x, range(1, x.shape[ax]), axis=ax)
        lo_ = a0
        hi_ = 0.5 * (a0 + a1)
        out = np.stack([lo_, hi_], axis=ax + 1)
        s = list(out.shape)
        s[ax] = s[ax] * 2
        del s[ax + 1]
        return out.reshape(s)
    up = p
    for ax in range(3):
        up = axis_up(up, ax)
    up = np.ascontiguousarray(up, dtype=np.float32)
    big = vdb.FloatGrid()
    big.name = "density"
    vs = g.transform.voxelSize()
    big.transform = vdb.createLinearTransform(voxelSize=vs[0] / 2.0)
    # index origin: old voxel lo-1 (the pad) at twice its index
    start = tuple(2 * (l - 1) for l in lo)
    big.copyFromArray(up, ijk=start, tolerance=0.0)
    big.prune(0.0)
    vdb.write(big_vdb, grids=[big])
    print("cloud256: %d active voxels; x2: %d" % (g.activeVoxelCount(), big.activeVoxelCount()), flush=True)

with open(src_scene) as f:
    sc = json.load(f)
sc["volume"]["file"] = os.path.abspath(src_vdb)
sc["environment"]["file"] = os.path.join(shared, "data", "env", "sunset.exr")
scenes = {"cloud256": dict(sc)}
big = json.loads(json.dumps(sc))
big["volume"]["file"] = os.path.abspath(big_vdb)
scenes["cloud256_x2"] = big
for name, s in scenes.items():
    with open(os.path.join(a.out, name + ".json"), "w") as f:
        json.dump(s, f, indent=1)

print("| scene | method | cold s | peak RSS MiB |")
print("|---|---|---|---|")
for m in a.methods.split(","):
    for name in scenes:
        cmd = ["/usr/bin/time", "-f", "%e %M", a.vsd, "render", os.path.join(a.out, name + ".json"), "--quiet",
               "--method", m, "--width", str(a.width), "--height", str(a.height), "--cache-dir", "none",
               "--output", os.path.join(a.out, "%s_%s.exr" % (name, m))]
        for kv in a.set:
            cmd += ["--set", kv]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            print("| %s | %s | failed: %s |" % (name, m, r.stderr.strip().splitlines()[-1:]))
            continue
        secs, kb = r.stderr.strip().splitlines()[-1].split()
        print("| %s | %s | %.1f | %.0f |" % (name, m, float(secs), float(kb) / 1024.0), flush=True)
