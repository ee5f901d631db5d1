# Build and render the Cycles equivalent of a vsd scene file (docs/architecture.md §3, §4, §10).
#
#   blender --background --factory-startup --python-exit-code 1 \
#       --python tests/cycles/cycles_scene.py -- --scene S.json --out OUT.exr \
#       [--samples N] [--width W] [--height H] [--seed K] [--frame F] [--threads T] \
#       [--step-rate R] [--voxel-centres openvdb|cycles] [--volume-biased]
#       [--time-json T.json] [--save-blend B.blend]
#
# The scene is built FROM THE SCENE FILE, field by field, with the mapping written in
# docs/scene-file.md's "Blender" columns, so that Cycles renders what vsd's `reference`
# method is meant to render:
#
# * volumes: each entry of `volumes` (or the single `volume` + `medium`) becomes its own
#   Volume object with its own material; Cycles adds overlapping volumes' extinction,
#   scattering and emission and mixes their phase functions, which is vsd's rule.
# * volume: the frame's concrete .vdb (#### replaced like vsd_frame_path) on a fresh Volume
#   datablock; matrix_world is set explicitly from volume.matrix (never left to the importer,
#   which rotates Houdini files). Volume precision FULL (Blender's default HALF quantises
#   the density) and clipping 0 (Blender's default 0.001 drops thin smoke from the volume's
#   bounding mesh; vsd keeps every non-zero voxel).
# * medium: Principled Volume, Density = medium.density, Color = albedo, Anisotropy,
#   Absorption Color black (so sigma_t = density * grid, sigma_s = albedo * sigma_t),
#   Density Attribute = volume.grid, Blackbody Intensity 0; emission: an Attribute node
#   reading volume.emission_grid, times emission_strength, into Emission Strength, with
#   Emission Color = emission_color.
# * world: Environment Texture (Closest: vsd looks up the nearest texel) fed by Texture
#   Coordinate Generated through a Mapping node (Point) with Z rotation = rotation_z,
#   Background Strength = strength; or a uniform Background colour.
# * lights: one Blender light per lights[] entry, its values as they are (Strength, Power,
#   Radius, Angle, Spot Size, Blend, Color), the object turned so its -Z is `direction`.
# * camera: camera-to-world matrix from the three camera forms exactly as
#   core/src/scene/scene.c builds it (look-at: right = f x up, up' = right x f, back = -f);
#   sensor fit AUTO and cam.angle = fov (so the angle spans the larger image dimension).
# * Cycles: CPU, N samples, fixed seed, Box filter of width 1, no denoising, no adaptive
#   sampling, no clamping, no filter glossy, 1024 bounces of every kind, volume step rate
#   0.25 (--step-rate) with max steps raised so long rays are not cut short, film
#   transparent, view transform Standard, multilayer float EXR with Combined, VolumeDir and
#   VolumeInd. Cycles 3.4-4.5 ray-march heterogeneous volumes: with a step of a quarter voxel
#   their bias is far below the Monte Carlo noise of these tests. Cycles 5.0 tracks them
#   with null scattering by default (step settings unused); --volume-biased ray-marches.
#
# Runs in Blender 3.4 and in the bpy wheels 4.2, 4.5, 5.0 (docs/cycles-crosscheck.md, "Newer
# Cycles"): use_nodes only before 5.0, the Attribute node's "Fac"/"Factor", the 4.x colour
# space names, 5.0's media_type and single-part (interleaved) EXR, and the half-voxel shift
# only where Cycles needs it (before 5.0).
#
# The wall time of bpy.ops.render.render (scene sync, BVH, volume upload and path tracing)
# goes to --time-json together with the settings used.
import argparse
import json
import math
import os
import re
import sys
import time

import bpy
import mathutils


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="cycles_scene.py")
    ap.add_argument("--scene", required=True, help="vsd scene file (version 1)")
    ap.add_argument("--out", required=True, help="output multilayer EXR")
    ap.add_argument("--samples", type=int)
    ap.add_argument("--width", type=int)
    ap.add_argument("--height", type=int)
    ap.add_argument("--seed", type=int)
    ap.add_argument("--frame", type=int, help="default: frames.start")
    ap.add_argument("--threads", type=int, default=0, help="0 = all cores")
    ap.add_argument("--step-rate", type=float, default=0.25, help="Cycles volume step rate")
    ap.add_argument("--volume-biased", action="store_true",
                    help="Cycles 5.0+: ray-march volumes (scene.cycles.volume_biased) instead of "
                         "5.0's default unbiased null-scattering tracking; ignored before 5.0, "
                         "which always ray-marches")
    ap.add_argument("--voxel-centres", choices=("openvdb", "cycles"), default="openvdb",
                    help="openvdb (default): render the field vsd and OpenVDB define (voxel i's "
                         "centre at index i): Cycles 3.4-4.5 put it at i + 0.5, so the object is "
                         "shifted there; Cycles 5.0 already samples at i (no shift); cycles: "
                         "never shift (Cycles' own convention, whatever the version)")
    ap.add_argument("--time-json", help="write render time and settings here")
    ap.add_argument("--save-blend", help="also save the built scene as a .blend")
    return ap.parse_args(argv)


# ---- the scene file ---------------------------------------------------------------------

def resolve(base, path):
    if not path:
        return ""
    if os.path.isabs(path) or path.startswith("blob:"):
        return path
    return os.path.join(base, path)


def frame_path(pattern, frame):
    """vsd_frame_path: the one run of '#' in the file name -> frame, zero-padded (C %0*d)."""
    d, name = os.path.split(pattern)
    m = list(re.finditer(r"#+", name))
    if not m:
        return pattern
    if len(m) > 1:
        raise SystemExit(f"{pattern}: more than one run of '#' in the file name")
    run = m[0]
    n = len(run.group(0))
    num = "%0*d" % (n, frame)
    return os.path.join(d, name[:run.start()] + num + name[run.end():])


def normalize(v):
    l = math.sqrt(sum(x * x for x in v))
    return [x / l for x in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def camera_matrix(cam):
    """Camera-to-world 4x4 (row-major rows) and fov, as core/src/scene/scene.c resolves them."""
    if "matrix" in cam:
        m = [float(x) for x in cam["matrix"]]
        rows = [m[0:4], m[4:8], m[8:12], m[12:16]]
        for c in range(3):  # Cycles drops the camera's scale; so does vsd
            l = math.sqrt(sum(rows[r][c] ** 2 for r in range(3)))
            for r in range(3):
                rows[r][c] /= l
    else:
        pos = cam.get("position", [0, -6, 1])
        target = cam.get("look_at", [0, 0, 0])
        up = cam.get("up", [0, 0, 1])
        f = normalize([target[i] - pos[i] for i in range(3)])
        x = normalize(cross(f, up))
        y = cross(x, f)
        rows = [[x[r], y[r], -f[r], pos[r]] for r in range(3)] + [[0, 0, 0, 1]]
    if "lens" in cam:
        fov = 2.0 * math.atan(cam.get("sensor_width", 36.0) / 2.0 / cam["lens"])
    else:
        fov = cam.get("fov", 2.0 * math.atan(18.0 / 50.0))
    return rows, fov


# ---- what differs between Blender versions (3.4, 4.2, 4.5, 5.0) -------------------------

def use_nodes(idblock):
    """Material/World use_nodes = True where it still means something: 5.0 deprecated it
    (node trees are always used; removal planned for 6.0)."""
    if bpy.app.version < (5, 0, 0):
        idblock.use_nodes = True
    return idblock.node_tree


def output_socket(node, *names):
    """The first output named one of `names`, else the one whose identifier is names[0]
    (5.0 renamed the Attribute node's "Fac" output "Factor"; its identifier stays "Fac")."""
    for n in names:
        if n in node.outputs:
            return node.outputs[n]
    for o in node.outputs:
        if o.identifier == names[0]:
            return o
    raise KeyError("%s: no output %s" % (node.bl_idname, " / ".join(names)))


def set_multilayer_exr(image_settings):
    """One single-part multilayer EXR on every version. 5.0 moved multilayer under
    media_type (which must be set first) and writes a part per pass by default: its
    use_exr_interleave ("legacy interleaved storage") keeps the single part that 3.4-4.5 --
    and vsd_exr_read, which reads only a file's first part -- use."""
    if hasattr(image_settings, "media_type"):
        image_settings.media_type = "MULTI_LAYER_IMAGE"
    image_settings.file_format = "OPEN_EXR_MULTILAYER"
    if hasattr(image_settings, "use_exr_interleave"):
        image_settings.use_exr_interleave = True


def cycles_voxel_centre():
    """Where this Blender's Cycles puts the centre of voxel i, in index coordinates minus i:
    0.5 up to 4.5 (its NanoVDB lookup interpolates at x - 0.5: kernel/device/gpu/image.h
    `frac(x - 0.5f, &ix)`; the CPU kernel measures the same), 0 from 5.0
    (kernel/util/texture_3d.h, shared by all devices, interpolates at floor(P) with no
    offset). Measured with test_cycles_crosscheck (docs/cycles-crosscheck.md, "Newer
    Cycles"): 5.0 with the shift, alpha 43x the noise floor; without, 0.77x."""
    return 0.5 if bpy.app.version < (5, 0, 0) else 0.0


def linear_colorspace():
    """The scene-linear Rec.709 image colour space: "Linear" in 3.x's OCIO config,
    "Linear Rec.709" from 4.0."""
    prop = bpy.types.ColorManagedInputColorspaceSettings.bl_rna.properties["name"]
    names = [i.identifier for i in prop.enum_items]
    for n in ("Linear Rec.709", "Linear"):
        if n in names:
            return n
    return "scene_linear"


# ---- building the Blender scene ---------------------------------------------------------

def clear_scene():
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.lights, bpy.data.cameras, bpy.data.materials,
                 bpy.data.volumes, bpy.data.worlds, bpy.data.images):
        for item in list(coll):
            coll.remove(item)


def scene_volumes(sc):
    """The scene's volumes as (volume fields, medium) pairs: `volumes`, or the single form."""
    if "volumes" in sc:
        return [(v, v.get("medium", {})) for v in sc["volumes"]]
    return [(sc["volume"], sc.get("medium", {}))]


def build_volume(vol_desc, scene, base, frame, voxel_centres, index=0):
    frame = frame + int(vol_desc.get("frame_offset", 0))
    path = frame_path(resolve(base, vol_desc["file"]), frame)
    if not os.path.isfile(path):
        raise SystemExit(f"volumes[{index}].file: {path}: no such file")
    vol = bpy.data.volumes.new("vsd_volume%d" % index)
    vol.filepath = path
    vol.is_sequence = False
    vol.render.precision = "FULL"
    vol.render.clipping = 0.0
    # density per WORLD length, as vsd's medium.density: with Blender's default "Object",
    # Cycles divides it by the object's scale along (1,1,1) (object_volume_density; the add-on
    # sends that product, mapping.object_space_density)
    vol.render.space = "WORLD"
    vol.render.step_size = 0.0  # automatic: one voxel, times the step rates below
    ob = bpy.data.objects.new("vsd_volume%d" % index, vol)
    scene.collection.objects.link(ob)
    m = [float(x) for x in vol_desc.get("matrix", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])]
    ob.matrix_world = mathutils.Matrix([m[0:4], m[4:8], m[8:12], m[12:16]])
    vol.grids.load()
    names = [g.name for g in vol.grids]
    grid = vol_desc.get("grid", "density")
    if isinstance(grid, int):
        # Blender addresses grids by name only; a repeated name reads the first of them.
        grid = names[grid] if grid < len(names) else ""
    if grid == "":
        floats = [g.name for g in vol.grids if g.data_type == "FLOAT"]
        grid = floats[0] if floats else "density"
    if grid not in names:
        raise SystemExit(f"volume.grid: {grid!r} not in {path} (grids: {names})")
    c = cycles_voxel_centre()
    if voxel_centres == "openvdb" and c != 0.0:
        # Cycles 3.4-4.5 sample voxel i at index coordinate i + 0.5 (the dense texture spans
        # [min, min + dim) with texel centres at +0.5; the NanoVDB path samples at x - 0.5),
        # while OpenVDB -- and vsd -- put voxel i's centre at index i. Moving the object by
        # half a voxel in the grid's index space makes Cycles render the OpenVDB field.
        # Cycles 5.0 samples at i itself: no shift.
        g = vol.grids[grid].matrix_object
        ob.matrix_world = ob.matrix_world @ g @ mathutils.Matrix.Translation((-c, -c, -c)) @ g.inverted()
    return ob, grid, path


def build_material(vol_desc, med, ob, grid):
    density = float(med.get("density", 1.0))
    albedo = med.get("albedo", [0.8, 0.8, 0.8])
    g = float(med.get("anisotropy", 0.0))
    ecol = med.get("emission_color", [1.0, 1.0, 1.0])
    estr = float(med.get("emission_strength", 0.0))
    egrid = vol_desc.get("emission_grid") or ""

    mat = bpy.data.materials.new("vsd_medium")
    nt = use_nodes(mat)
    if hasattr(mat.cycles, "homogeneous_volume"):  # gone in 5.0 (null scattering decides)
        mat.cycles.homogeneous_volume = False
    mat.cycles.volume_interpolation = "LINEAR"  # trilinear, as vsd
    mat.cycles.volume_sampling = "MULTIPLE_IMPORTANCE"
    mat.cycles.volume_step_rate = 1.0           # the scene-wide rate does the work
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Color"].default_value = (albedo[0], albedo[1], albedo[2], 1.0)
    pv.inputs["Density"].default_value = density
    pv.inputs["Density Attribute"].default_value = grid
    pv.inputs["Anisotropy"].default_value = g
    pv.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    pv.inputs["Blackbody Intensity"].default_value = 0.0
    pv.inputs["Emission Strength"].default_value = 0.0
    if estr > 0.0 and egrid:
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.attribute_type = "GEOMETRY"
        attr.attribute_name = egrid
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = "MULTIPLY"
        mul.inputs[1].default_value = estr
        nt.links.new(output_socket(attr, "Fac", "Factor"), mul.inputs[0])
        nt.links.new(mul.outputs["Value"], pv.inputs["Emission Strength"])
        pv.inputs["Emission Color"].default_value = (ecol[0], ecol[1], ecol[2], 1.0)
    nt.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    ob.data.materials.append(mat)
    return mat


def build_world(sc, scene, base):
    env = sc.get("environment", {})
    world = bpy.data.worlds.new("vsd_world")
    scene.world = world
    nt = use_nodes(world)
    world.cycles.sampling_method = "AUTOMATIC"
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = float(env.get("strength", 1.0))
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    file = env.get("file") or ""
    if file:
        img = bpy.data.images.load(resolve(base, file), check_existing=False)
        cs = env.get("colorspace") or ""
        img.colorspace_settings.name = cs if cs else linear_colorspace()
        tc = nt.nodes.new("ShaderNodeTexCoord")
        mp = nt.nodes.new("ShaderNodeMapping")
        mp.vector_type = "POINT"
        mp.inputs["Rotation"].default_value = (0.0, 0.0, float(env.get("rotation_z", 0.0)))
        tex = nt.nodes.new("ShaderNodeTexEnvironment")
        tex.image = img
        tex.interpolation = "Closest" if env.get("interpolation") == "closest" else "Linear"
        tex.projection = "EQUIRECTANGULAR"
        nt.links.new(tc.outputs["Generated"], mp.inputs["Vector"])
        nt.links.new(mp.outputs["Vector"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    else:
        c = env.get("color") or [0.05, 0.05, 0.05]
        bg.inputs["Color"].default_value = (c[0], c[1], c[2], 1.0)
    return world


def build_lights(sc, scene):
    """lights[] (docs/scene-file.md) as Blender lights: the keys are Blender's own values
    (Strength W/m^2, Power W, Radius, Angle, Spot Size, Blend); a light shines down its
    local -Z, so the object's -Z is turned to `direction`."""
    for i, l in enumerate(sc.get("lights", [])):
        kind = l["type"].upper()
        data = bpy.data.lights.new("light%d" % i, kind)
        data.color = tuple(l.get("color", [1.0, 1.0, 1.0]))
        if kind == "SUN":
            data.energy = float(l.get("strength", 1.0))
            data.angle = float(l.get("angle", 0.0))
        else:
            data.energy = float(l.get("power", 1000.0))
            data.shadow_soft_size = float(l.get("radius", 0.0))
        if kind == "SPOT":
            data.spot_size = float(l.get("spot_size", math.pi / 4))
            data.spot_blend = float(l.get("spot_blend", 0.15))
        ob = bpy.data.objects.new("light%d" % i, data)
        scene.collection.objects.link(ob)
        rot = mathutils.Vector(l.get("direction", [0.0, 0.0, -1.0])).to_track_quat("-Z", "Y").to_matrix().to_4x4()
        ob.matrix_world = mathutils.Matrix.Translation(l.get("position", [0.0, 0.0, 0.0])) @ rot


def build_camera(sc, scene, width, height):
    cam_desc = sc.get("camera", {})
    rows, fov = camera_matrix(cam_desc)
    cam = bpy.data.cameras.new("vsd_camera")
    cam.sensor_fit = "AUTO"
    cam.sensor_width = float(cam_desc.get("sensor_width", 36.0))
    if cam_desc.get("type", "perspective") == "orthographic":
        cam.type = "ORTHO"
        cam.ortho_scale = float(cam_desc.get("ortho_scale", 7.3142857))
    else:
        cam.type = "PERSP"
        cam.angle = fov
    cam.clip_start = float(cam_desc.get("clip_start", 0.1))
    cam.clip_end = float(cam_desc.get("clip_end", 1000.0))
    cam.shift_x = cam.shift_y = 0.0
    ob = bpy.data.objects.new("vsd_camera", cam)
    scene.collection.objects.link(ob)
    ob.matrix_world = mathutils.Matrix(rows)
    scene.camera = ob
    return ob


def configure_cycles(scene, args, samples, seed, width, height, transparent):
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.seed = seed
    c.use_animated_seed = False
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.max_bounces = 1024
    c.volume_bounces = 1024
    c.diffuse_bounces = 1024
    c.glossy_bounces = 1024
    c.transmission_bounces = 1024
    c.transparent_max_bounces = 1024
    c.volume_step_rate = args.step_rate
    if hasattr(c, "volume_biased"):  # 5.0: null scattering by default, ray marching if biased
        c.volume_biased = bool(getattr(args, "volume_biased", False))
    c.volume_max_steps = 100000
    c.light_sampling_threshold = 0.0
    if hasattr(c, "use_guiding"):
        c.use_guiding = False
    if hasattr(c, "use_fast_gi"):
        c.use_fast_gi = False
    r = scene.render
    r.resolution_x = width
    r.resolution_y = height
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = bool(transparent)
    r.use_border = False
    r.use_persistent_data = False
    if args.threads > 0:
        r.threads_mode = "FIXED"
        r.threads = args.threads
    else:
        r.threads_mode = "AUTO"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    set_multilayer_exr(r.image_settings)
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    r.use_compositing = False
    r.use_sequencer = False
    vl = scene.view_layers[0]
    vl.name = "ViewLayer"
    vl.use_pass_combined = True
    vl.use_pass_z = False
    vl.cycles.use_pass_volume_direct = True
    vl.cycles.use_pass_volume_indirect = True
    vl.use_pass_emit = True


def main():
    args = parse_args()
    with open(args.scene) as f:
        sc = json.load(f)
    if sc.get("version") != 1:
        raise SystemExit(f"{args.scene}: version: expected 1")
    base = os.path.dirname(os.path.abspath(args.scene))
    film = sc.get("film", {})
    rnd = sc.get("render", {})
    width = args.width or int(film.get("width", 640))
    height = args.height or int(film.get("height", 360))
    samples = args.samples or int(rnd.get("samples", 64))
    seed = args.seed if args.seed is not None else int(rnd.get("seed", 1))
    frame = args.frame if args.frame is not None else int(sc.get("frames", {}).get("start", 1))

    scene = bpy.context.scene
    clear_scene()
    scene.frame_set(frame)
    vdb_paths = []
    for i, (vol_desc, med) in enumerate(scene_volumes(sc)):
        ob, grid, vdb_path = build_volume(vol_desc, scene, base, frame, args.voxel_centres, i)
        build_material(vol_desc, med, ob, grid)
        vdb_paths.append(vdb_path)
    vdb_path = vdb_paths[0] if len(vdb_paths) == 1 else vdb_paths
    build_world(sc, scene, base)
    build_lights(sc, scene)
    build_camera(sc, scene, width, height)
    configure_cycles(scene, args, samples, seed, width, height, film.get("transparent", True))

    out = os.path.abspath(args.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    scene.render.filepath = out
    scene.render.use_file_extension = False
    if args.save_blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save_blend))
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    if not os.path.isfile(out):
        raise SystemExit(f"Cycles wrote no {out}")
    print(f"cycles_scene: {width}x{height}, {samples} spp, seed {seed}, frame {frame}: "
          f"{seconds:.2f} s -> {out}")
    if args.time_json:
        with open(args.time_json, "w") as f:
            json.dump({"render_seconds": seconds, "samples": samples, "width": width,
                       "height": height, "seed": seed, "frame": frame, "vdb": vdb_path,
                       "grid": grid, "step_rate": args.step_rate,
                       "voxel_centres": args.voxel_centres,
                       "cycles_voxel_centre": cycles_voxel_centre(),
                       "volume_biased": bool(getattr(scene.cycles, "volume_biased", True)),
                       "threads": scene.render.threads, "blender": bpy.app.version_string},
                      f, indent=1)


if __name__ == "__main__":
    try:
        main()
    except SystemExit as e:
        if e.code not in (None, 0):
            print(f"cycles_scene.py: {e.code}", file=sys.stderr)
            sys.exit(1)
