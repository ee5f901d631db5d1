# The add-on's mapping against Cycles itself (issue 6, "Tests"): the scene an artist builds
# in Blender, exported by File > Export > vsd scene (.json) and rendered by vsd's `reference`
# method, matches the SAME Blender scene rendered by Cycles in this Blender -- not a Cycles
# scene rebuilt from the JSON (that is tests/cycles/cycles_scene.py's job, which checks
# `reference` itself). What is compared is therefore the mapping: Volume object and
# matrix_world (with the half-voxel shift to Blender's voxel centres), Principled Volume
# Density / Color / Anisotropy / Density Attribute, the world's Environment Texture through a
# Mapping Z rotation and Background Strength, the camera and the film.
#
# Scene: smoke64 frame 24 as a Volume sequence (scene frame 24 = file 24 through frame_offset),
# moved by (0.1, 0, -0.05) and scaled by 0.8 (Blender's default volume Space "Object": Cycles
# divides the density by the scale, the add-on sends density 30 / 0.8); density 30, Color (0.9, 0.8, 0.7) (a per-channel check), anisotropy
# 0.4 (a sign error shows); studio.exr rotated by 1.2 rad with strength 1.3; a 50 mm camera
# 6 m away; 96x54, transparent film -- the scene of the foundation's cross-check
# (docs/cycles-crosscheck.md), whose noise study gives the bounds used here.
#
# Renders: vsd `reference` of the exported file at 2048 spp, seeds 1 and 2 (`vsd render`);
# Cycles at 512 spp, seeds 1 and 2, with the cross-check's Cycles settings
# (configure_cycles() of tests/cycles/cycles_scene.py: Box filter 1 px, no denoising or
# adaptive sampling or clamping, 1024 bounces, volume step rate 0.25) and the Volume
# datablock's Cycles quality settings (precision Full, clipping 0), which have no vsd
# counterpart. The four EXRs are compared by `test_cycles_crosscheck --compare`: relative RMSE
# after 4x4 blocks of the vsd pair mean against the Cycles pair mean, bounded by K x the noise
# floor measured from the seed pairs, and the mean difference by 4 se + 0.5 %, for Combined
# RGB, alpha, VolumeDir, VolumeInd, and Emit black in both.
#
# Usage: blender -b --factory-startup --python-exit-code 1 --python test_cycles.py -- \
#            VSD DATA TMP COMPARE_EXE
import json
import math
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

sys.path.insert(0, os.path.join(common.REPO, "tests", "cycles"))
import cycles_scene  # noqa: E402  (its main() only runs as a script)

import bpy  # noqa: E402

WIDTH, HEIGHT = 96, 54
FRAME = 24
SCALE = 0.8   # the object's uniform scale (tests the object-space density)
VSD_SPP, CYCLES_SPP = 2048, 512
SEEDS = (1, 2)


class CyclesArgs(object):
    """What configure_cycles() reads from cycles_scene.py's command line."""
    step_rate = 0.25
    threads = 0


def main():
    vsd, data, tmp, rest = common.args()
    compare = os.path.abspath(rest[0])
    common.fresh_tmp(tmp)
    common.install_addon(tmp, vsd=vsd)
    t0 = time.time()

    # --- the artist's scene ------------------------------------------------------------------
    scene, ob = common.build_scene(data, width=WIDTH, height=HEIGHT, frame_start=FRAME, frame_offset=FRAME - 1,
                                    rotation_deg=math.degrees(1.2), strength=1.3, density=30.0,
                                    color=(0.9, 0.8, 0.7), anisotropy=0.4, cam_pos=(-1.521, -4.3949, 1.835),
                                    cam_target=(0.99, 0.99, 1.0), lens=50.0)
    check(scene.view_layers[0].name == "ViewLayer", "view layer ViewLayer (the names --compare reads)")
    ob.scale = (SCALE, SCALE, SCALE)
    scene.frame_set(FRAME)
    bpy.context.view_layer.update()
    check(ob.data.render.space == "OBJECT", "the volume's Space is Blender's default, Object")
    s = scene.vsd
    s.method = "reference"
    s.samples = VSD_SPP
    s.seed = SEEDS[0]

    # --- File > Export > vsd scene -----------------------------------------------------------
    scene_json = os.path.join(tmp, "export", "scene.json")
    os.makedirs(os.path.dirname(scene_json))
    res = bpy.ops.export_scene.vsd(filepath=scene_json, frame_range=False)
    check(res == {"FINISHED"}, "export operator finished (%s)" % res)
    sc = json.load(open(scene_json))
    print("exported:", json.dumps(sc))
    check(sc["frames"] == {"start": FRAME, "end": FRAME}, "exported frame %s" % sc["frames"])
    check(len(sc["volumes"]) == 1, "one volume: volumes holds one entry (%d)" % len(sc["volumes"]))
    medium = sc["volumes"][0]["medium"]
    # Cycles' object_volume_density: 1 / |M (1,1,1)/sqrt(3)| = 1 / 0.8
    check(abs(medium["density"] - 30.0 / SCALE) < 1e-4 and abs(medium["anisotropy"] - 0.4) < 1e-6 and
          [round(x, 6) for x in medium["albedo"]] == [0.9, 0.8, 0.7],
          "Principled Volume -> medium %s" % medium)
    check(abs(sc["environment"]["rotation_z"] - 1.2) < 1e-6 and abs(sc["environment"]["strength"] - 1.3) < 1e-6,
          "world -> environment %s" % {k: v for k, v in sc["environment"].items() if k != "file"})
    check(sc["output"]["pass_names"] == {n: common.blender_pass(n) for n in sc["output"]["passes"]},
          "Blender %s: output.pass_names are this version's %s" % (bpy.app.version_string, sc["output"]["pass_names"]))
    # smoke64's voxels are 1/32 m: up to 4.5 Cycles centres voxel i at i + 1/2, so the add-on
    # moves the volume by +1/64 m on every axis (the grid is axis-aligned) on top of
    # matrix_world; 5.0's Cycles centres it at i, as vsd does: no shift
    # (docs/cycles-crosscheck.md, "Newer Cycles").
    want = SCALE / 64.0 if bpy.app.version < (5, 0, 0) else 0.0
    m = sc["volumes"][0]["matrix"]
    mw = ob.matrix_world
    shift = [m[3] - mw[0][3], m[7] - mw[1][3], m[11] - mw[2][3]]
    check(all(abs(d - want) < 1e-6 for d in shift),
          "volumes[0].matrix = matrix_world moved by %g m per axis (%s)" % (want, shift))

    # --- vsd reference of the exported file ----------------------------------------------------
    vexr = []
    for seed in SEEDS:
        out = os.path.join(tmp, "vsd_seed%d_####.exr" % seed)
        t = time.time()
        r = subprocess.run([vsd, "render", scene_json, "--frames", str(FRAME), "--seed", str(seed),
                            "--output", out, "--quiet"], capture_output=True, text=True)
        check(r.returncode == 0, "vsd render seed %d (%s)" % (seed, r.stderr.strip()))
        vexr.append(out.replace("####", "%04d" % FRAME))
        print("vsd reference seed %d: %d spp, %.1f s" % (seed, VSD_SPP, time.time() - t), flush=True)

    # --- Cycles of the same Blender scene --------------------------------------------------------
    vol = ob.data
    vol.render.precision = "FULL"   # Blender's default HALF quantises the density
    vol.render.clipping = 0.0       # its default 0.001 drops thin smoke from the volume's mesh
    cycles_scene.configure_cycles(scene, CyclesArgs(), CYCLES_SPP, SEEDS[0], WIDTH, HEIGHT, True)
    cexr = []
    for seed in SEEDS:
        scene.cycles.seed = seed
        out = os.path.join(tmp, "cycles_seed%d.exr" % seed)
        t = time.time()
        err = common.run_blender_render(out)
        check(err is None and os.path.isfile(out), "Cycles render seed %d (%s)" % (seed, err))
        cexr.append(out)
        print("Cycles seed %d: %d spp, %.1f s" % (seed, CYCLES_SPP, time.time() - t), flush=True)

    # --- the cross-check's comparison and noise-derived bounds -------------------------------------
    if all(os.path.isfile(p) for p in vexr + cexr):
        r = subprocess.run([compare, "--compare"] + vexr + cexr, capture_output=True, text=True)
        print(r.stdout + r.stderr, flush=True)
        check(r.returncode == 0, "vsd reference of the export matches Cycles of the Blender scene "
                                 "within the noise-derived bounds (test_cycles_crosscheck --compare)")
    print("time: %.1f s" % (time.time() - t0), flush=True)
    common.finish("test_cycles")


main()
