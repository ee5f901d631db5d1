# Blender scene -> vsd scene file v1 (docs/architecture.md §3, §4; docs/blender-addon.md has the table).
#
# build_scene() reads the evaluated depsgraph: every volume object the view layer renders
# (each an entry of `volumes`: its current frame's .vdb, matrix_world, its material's
# Principled Volume as its medium), the world's Environment Texture or uniform Background
# colour, the camera and the film. It returns the scene as a dict whose volumes[].file and
# environment.file are LOCAL paths (the engine swaps them for blob names, with_blobs(), the
# exporter for paths relative to the scene file), plus the warnings for
# everything it could not map: those go to Blender's report area, never silently away.
import math
import os
import re
import tempfile

import bpy

from . import colour, light_units, method_catalog, passes

DEFAULT_FOV = 2.0 * math.atan(18.0 / 50.0)


def node_tree(idblock):
    """The node tree a material or world renders with, or None. 5.0 deprecated use_nodes
    (always on, removal planned for 6.0): reading it there only warns, so it is read before
    5.0 only."""
    nt = getattr(idblock, "node_tree", None)
    if nt is None:
        return None
    if bpy.app.version < (5, 0, 0) and not idblock.use_nodes:
        return None
    return nt


class MappingError(Exception):
    """The scene cannot be rendered by vsd at all (no camera, no volume object, ...)."""


class NoFileAtFrame(MappingError):
    """A volume sequence shows no file at this frame (Clip mode outside its range)."""


# vsd's own limit (core/include/vsd/scene.h VSD_MAX_VOLUMES; the scene parser refuses more)
MAX_VOLUMES = 16


class VolumeMap(object):
    """One volume object as sent: its volumes[] entry (with the LOCAL path of the current
    frame's file), that path, and the sequence as a #### pattern (for the export)."""

    def __init__(self, ob, entry, path, pattern):
        self.object = ob          # the evaluated object
        self.entry = entry        # the dict in scene["volumes"]
        self.path = path          # the current frame's .vdb (absolute)
        self.pattern = pattern    # the sequence as a #### pattern (absolute), or the path


class Mapping(object):
    """What build_scene() found: the scene dict, the files it references, and notes."""

    def __init__(self):
        self.scene = {}
        self.volumes = []             # VolumeMap per entry of scene["volumes"], in order
        self.env_path = None          # environment map file (absolute) or None
        self.method = ""              # the method the scene asks for ("" = the daemon's default)
        self.fallback_from = ""       # the viewport's chosen method when it fell back, else ""
        self.warnings = []

    def warn(self, msg):
        if msg not in self.warnings:
            self.warnings.append(msg)

    def files(self):
        """The local files to upload: each volume's current frame, then the map."""
        out = list(dict.fromkeys(v.path for v in self.volumes))
        if self.env_path:
            out.append(self.env_path)
        return out

    def with_blobs(self, names):
        """The scene with its files replaced by the daemon's blob names ({path: blob})."""
        return with_blobs(self.scene, names)


def with_blobs(scene, names):
    """A copy of scene dict `scene` whose volumes[].file and environment.file are replaced by
    names[file] (upload's {path: "blob:<hash>"}); other fields are shared."""
    sc = dict(scene)
    sc["volumes"] = [dict(v, file=names.get(v.get("file"), v.get("file"))) for v in scene.get("volumes", [])]
    env = scene.get("environment")
    if isinstance(env, dict) and env.get("file") in names:
        sc["environment"] = dict(env, file=names[env["file"]])
    return sc


# ---- volume ------------------------------------------------------------------------------
#
# Every Volume object that the view layer renders goes (docs/blender-addon.md, "Several
# volumes"): F12 and the export leave out objects disabled for renders (hide_render, and
# whatever Blender's depsgraph leaves out: excluded or render-disabled collections), the
# viewport what its depsgraph does not show (hidden, disabled in viewports); holdouts
# (object or collection) and objects whose material has no volume shader never go, each
# with a note. An object with no material at all goes with Principled Volume defaults, as
# Cycles renders it with its default volume shader.

def _key(ob):
    lib = getattr(ob, "library", None)
    return (ob.name, lib.filepath if lib is not None else "")


def holdout_keys(view_layer):
    """_key() of every object in a collection set to Holdout in the view layer."""
    out = set()

    def walk(lc):
        if getattr(lc, "holdout", False):
            out.update(_key(o) for o in lc.collection.all_objects)
        for child in lc.children:
            walk(child)
    try:
        walk(view_layer.layer_collection)
    except Exception:
        pass
    return out


def volume_material_state(ob):
    """'volume' when the object's material feeds a Volume output, 'none' when it has no
    material (Cycles then renders its default volume shader), 'surface' when its material
    has no volume shader (Cycles renders nothing of it)."""
    mat = ob.active_material
    if mat is None:
        return "none"
    nt = node_tree(mat)
    if nt is None:
        return "surface"
    out = _output_node(nt)
    if out is None or "Volume" not in out.inputs or not out.inputs["Volume"].is_linked:
        return "surface"
    return "volume"


def skip_reason(orig, holdouts):
    """Why an original Volume object that the view layer shows is not sent, or None."""
    if getattr(orig, "is_holdout", False) or _key(orig) in holdouts:
        return "volume '%s' is a holdout: not rendered (vsd renders no holdouts)" % orig.name
    if volume_material_state(orig) == "surface":
        return ("volume '%s': its material '%s' has no volume shader (nothing feeds Material Output "
                "> Volume): not rendered, as in Cycles" % (orig.name, orig.active_material.name))
    return None


def volume_objects(depsgraph, m=None, final=None):
    """The Volume objects to send, evaluated, sorted by name: those of the depsgraph's view
    layer, without holdouts and objects whose material has no volume shader, and for a
    final render or an export (`final`, default: a RENDER depsgraph) without objects
    disabled for renders (also when the depsgraph is the viewport's, as the export's is).
    Why each other shown volume is left out goes to m.warn."""
    if final is None:
        final = depsgraph.mode == "RENDER"
    holdouts = holdout_keys(depsgraph.view_layer)
    obs = []
    for ob in depsgraph.objects:
        if ob.type != "VOLUME":
            continue
        orig = ob.original
        if final and orig.hide_render:
            continue
        why = skip_reason(orig, holdouts)
        if why:
            if m is not None:
                m.warn(why)
            continue
        obs.append(ob)
    return sorted(obs, key=lambda o: _key(o))


def count_volumes(scene, view_layer, final=True):
    """How many volumes a render of view_layer would send, from the original data (for the
    panels and menus, which have no depsgraph to ask): volume_objects() by Blender's own
    visibility flags."""
    holdouts = holdout_keys(view_layer)
    n = 0
    for ob in view_layer.objects:
        if ob.type != "VOLUME":
            continue
        try:
            if final:
                if ob.hide_render or any(c.hide_render for c in ob.users_collection):
                    continue
            elif not ob.visible_get(view_layer=view_layer):
                continue
        except Exception:
            pass
        if skip_reason(ob, holdouts) is None:
            n += 1
    return n


def fluid_domains(depsgraph, final=None):
    """Visible objects with a Mantaflow Fluid modifier of type Domain: (name, the cache's
    VDB pattern or None when the cache is not OpenVDB), sorted by name."""
    if final is None:
        final = depsgraph.mode == "RENDER"
    out = []
    for ob in depsgraph.objects:
        orig = ob.original
        if final and orig.hide_render:
            continue
        for mod in getattr(orig, "modifiers", []):
            if mod.type == "FLUID" and mod.fluid_type == "DOMAIN":
                ds = mod.domain_settings
                pattern = None
                if ds.cache_data_format == "OPENVDB":
                    pattern = os.path.join(bpy.path.abspath(ds.cache_directory, library=orig.library),
                                           "data", "fluid_data_####.vdb")
                out.append((ob.name, pattern))
    return sorted(out)


def _domain_note(name, pattern):
    if pattern:
        return ("'%s' is a Mantaflow fluid domain, which vsd does not read: import its baked "
                "cache %s with Add > Volume > Import OpenVDB" % (name, pattern))
    return ("'%s' is a Mantaflow fluid domain, which vsd does not read: bake it with Cache > "
            "Format Volumes OpenVDB, then import data/fluid_data_####.vdb with Add > Volume > "
            "Import OpenVDB" % name)


def pick_volumes(depsgraph, m, final):
    """The volume objects to send (volume_objects), at most MAX_VOLUMES; an error when there
    is none (naming a Mantaflow domain, or why the shown ones are left out) or too many."""
    notes = len(m.warnings)
    obs = volume_objects(depsgraph, m, final)
    domains = fluid_domains(depsgraph, final)
    if not obs:
        if domains:
            raise MappingError("no visible Volume object to render: " + _domain_note(*domains[0]))
        why = m.warnings[notes:]
        raise MappingError("no visible Volume object to render (Add > Volume > Import OpenVDB)"
                           + (": " + "; ".join(why) if why else ""))
    if len(obs) > MAX_VOLUMES:
        raise MappingError("%d volume objects to render: vsd renders at most %d in one scene (hide some, "
                           "or disable them for renders)" % (len(obs), MAX_VOLUMES))
    for name, pattern in domains:
        m.warn(_domain_note(name, pattern) + " (not rendered)")
    return obs


_DIGITS = re.compile(r"(\d+)(?!.*\d)")


def _split_frame(path):
    """(head, digits, tail) of the last run of digits in the file name, or None (Blender's
    BLI_path_frame_get looks at the file name's last number too)."""
    d, name = os.path.split(path)
    stem, ext = os.path.splitext(name)
    mm = _DIGITS.search(stem)
    if not mm:
        return None
    return os.path.join(d, stem[:mm.start()]), mm.group(1), stem[mm.end():] + ext


def sequence_frame(vol, scene_frame):
    """Blender's BKE_volume_sequence_frame: the file frame number shown at scene_frame, or
    None when the sequence shows nothing (Clip mode outside the range)."""
    dur = vol.frame_duration
    if dur == 0:
        return None
    f = scene_frame - vol.frame_start + 1
    mode = vol.sequence_mode
    if mode == "CLIP":
        if f < 1 or f > dur:
            return None
    elif mode == "EXTEND":
        f = min(max(f, 1), dur)
    elif mode == "REPEAT":
        f = f % dur
        if f < 0:
            f += dur
        if f == 0:
            f = dur
    elif mode == "PING_PONG":
        pp = dur * 2 - 2
        if pp <= 0:
            f = 1
        else:
            f = f % pp
            if f < 0:
                f += pp
            if f == 0:
                f = pp
            if f > dur:
                f = dur * 2 - f
    return f + vol.frame_offset


def volume_file(vol, scene_frame):
    """Absolute path of the .vdb that Volume data `vol` (original) shows at scene_frame."""
    path = bpy.path.abspath(vol.filepath, library=vol.library)
    if not vol.is_sequence:
        return os.path.normpath(path)
    parts = _split_frame(path)
    if parts is None:
        return os.path.normpath(path)
    f = sequence_frame(vol, scene_frame)
    if f is None:
        return None
    head, digits, tail = parts
    return os.path.normpath("%s%0*d%s" % (head, len(digits), f, tail))


def volume_pattern(vol):
    """The sequence as a vsd #### pattern (absolute), or the plain path."""
    path = os.path.normpath(bpy.path.abspath(vol.filepath, library=vol.library))
    if not vol.is_sequence:
        return path
    parts = _split_frame(path)
    if parts is None:
        return path
    head, digits, tail = parts
    return "%s%s%s" % (head, "#" * len(digits), tail)


def _write_packed_volume(vol):
    data = vol.packed_file.data
    fd, path = tempfile.mkstemp(prefix="vsd_packed_", suffix=".vdb")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    return path


def map_volume(ob, scene_frame, m):
    """(the volumes[] entry {"file": the current frame's .vdb}, that path, the sequence's
    #### pattern) of volume object `ob` at scene_frame."""
    vol_eval = ob.data
    vol = vol_eval.original if hasattr(vol_eval, "original") else vol_eval
    path = ""
    if vol.packed_file is not None:
        path = _write_packed_volume(vol)
        m.warn("volume '%s' is packed in the .blend: sending a temporary copy" % vol.name)
    else:
        try:
            path = vol_eval.grids.frame_filepath  # Blender's own choice for this frame
        except Exception:
            path = ""
        if path:
            path = os.path.normpath(bpy.path.abspath(path, library=vol.library))
        else:
            path = volume_file(vol, scene_frame)
    if not path:
        raise NoFileAtFrame("volume '%s' shows no file at frame %d (sequence mode %s)"
                            % (vol.name, scene_frame, vol.sequence_mode))
    if not os.path.isfile(path):
        raise MappingError("volume '%s': file not found: %s" % (vol.name, path))
    if len(ob.original.modifiers):
        m.warn("volume '%s': modifiers are ignored (vsd renders the .vdb file as stored)" % ob.name)
    pattern = volume_pattern(vol) if vol.packed_file is None else path
    return {"file": path}, path, pattern


def voxel_centres_offset(version=None):
    """Whether this Blender's Cycles centres voxel i at index i + 1/2 (before 5.0)."""
    return tuple((version or bpy.app.version)[:2]) < (5, 0)


def voxel_centre_matrix(ob, grid, m):
    """The object matrix to send for grid `grid`: matrix_world . G . T(1/2) . G^-1.

    Blender's Cycles (and the viewport) put the centre of voxel i at index coordinate
    i + 1/2; vsd, like OpenVDB, at i (docs/design-notes.md; measured in
    docs/cycles-crosscheck.md, finding 1). Moving the volume by half a voxel in the grid's
    index space (G = the grid's index-to-object matrix) makes vsd render the field where
    Cycles renders it, so a vsd pass composites exactly over a Cycles render of the scene;
    tests/blender_addon/test_cycles.py checks it against Cycles itself. Only the density
    grid's transform is used (an emission grid with another transform keeps a residual).

    Blender 5.0's Cycles centres voxel i at i, as OpenVDB and vsd do (its 3D texture lookup
    lost the half-texel offset; docs/cycles-crosscheck.md, "Newer Cycles"): from 5.0 the
    object's matrix is sent as it is (with the 3.4 shift, 5.0's alpha was 43x the noise
    floor off, without it 0.8x)."""
    import mathutils
    mw = ob.matrix_world.copy()
    if not voxel_centres_offset():
        return [float(mw[r][c]) for r in range(4) for c in range(4)]
    grids = ob.data.grids
    try:
        grids.load()
    except Exception:
        pass
    g = None
    if grid and grid in grids:
        g = grids[grid]
    else:
        floats = [x for x in grids if x.data_type == "FLOAT"]
        g = floats[0] if floats else None
    if g is None:
        m.warn("volume '%s': no float grid to take the voxel size from: sent without the "
               "half-voxel shift to Blender's voxel centres" % ob.name)
    else:
        gm = g.matrix_object
        try:
            gi = gm.inverted()
        except ValueError:
            gi = None
        if gi is None:
            m.warn("grid '%s' has a singular transform: sent without the half-voxel shift" % g.name)
        else:
            mw = mw @ gm @ mathutils.Matrix.Translation((0.5, 0.5, 0.5)) @ gi
    return [float(mw[r][c]) for r in range(4) for c in range(4)]


# ---- material ----------------------------------------------------------------------------

def _follow(socket):
    """The node and output socket feeding `socket`, skipping reroutes; (None, None) if none."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None, None
        node = link.from_node
        if node.type == "REROUTE":
            socket = node.inputs[0]
            continue
        return node, link.from_socket
    return None, None


def _color(v):
    return [float(v[0]), float(v[1]), float(v[2])]


def _clamp01(c, what, m):
    out = [min(max(x, 0.0), 1.0) for x in c]
    if out != c:
        m.warn("%s %s clamped to 0..1" % (what, [round(x, 4) for x in c]))
    return out


def _output_node(nt):
    for target in ("CYCLES", "ALL"):
        try:
            n = nt.get_output_node(target)
        except Exception:
            n = None
        if n is not None:
            return n
    outs = [n for n in nt.nodes if n.type in ("OUTPUT_MATERIAL", "OUTPUT_WORLD")]
    return outs[0] if outs else None


def _emission_strength(sock, m):
    """(strength, grid) for an Emission Strength socket: a constant, an Attribute node, or an
    Attribute node times a constant (Math Multiply)."""
    if not sock.is_linked:
        return float(sock.default_value), ""
    node, out = _follow(sock)
    scale = 1.0
    if node is not None and node.type == "MATH" and node.operation == "MULTIPLY":
        a, b = node.inputs[0], node.inputs[1]
        src = None
        if a.is_linked and not b.is_linked:
            src, scale = a, float(b.default_value)
        elif b.is_linked and not a.is_linked:
            src, scale = b, float(a.default_value)
        if src is not None:
            node, out = _follow(src)
        else:
            node = None
        if node is not None and getattr(node, "use_clamp", False):
            m.warn("Emission Strength: the Math node's Clamp is ignored")
    # 5.0 renamed the Attribute node's "Fac" output "Factor" (its identifier stays "Fac")
    if node is not None and node.type == "ATTRIBUTE" and (out.identifier in ("Fac", "Color")
                                                          or out.name in ("Fac", "Factor", "Color")):
        if node.attribute_type not in ("GEOMETRY",):
            m.warn("Emission Strength: Attribute node type %s treated as Geometry" % node.attribute_type)
        return scale, node.attribute_name
    m.warn("Emission Strength: only an Attribute node (optionally times a constant) can be "
           "mapped; emission ignored")
    return 0.0, ""


def object_space_density(ob):
    """What Cycles multiplies a volume's density and emission by: with the Volume data's
    render Space "Object" (Blender's default) "volume density automatically adjusts to
    object scale", by 1 / |M . normalize(1, 1, 1)| with M matrix_world's 3x3 part (Cycles'
    object_volume_density; scaling the object by 0.5 doubles the density per world length);
    with "World", 1. vsd's medium.density is per world length, so the add-on sends the
    product (docs/cycles-crosscheck.md, "Scaled volume objects")."""
    render = getattr(getattr(ob, "data", None), "render", None)
    if render is None or getattr(render, "space", "OBJECT") != "OBJECT":
        return 1.0
    mw = ob.matrix_world
    u = 1.0 / math.sqrt(3.0)
    d = [sum(mw[r][c] * u for c in range(3)) for r in range(3)]
    length = math.sqrt(sum(x * x for x in d))
    return 1.0 / length if length > 0.0 else 1.0


def map_material(ob, grids, m):
    """Principled Volume -> (medium dict, density grid name, emission grid name)."""
    medium = {"density": 1.0, "albedo": [0.5, 0.5, 0.5], "anisotropy": 0.0,
              "emission_color": [1.0, 1.0, 1.0], "emission_strength": 0.0}
    mat = ob.active_material
    if mat is None:
        m.warn("volume '%s' has no material: using Principled Volume defaults" % ob.name)
        return medium, "density", ""
    nt = node_tree(mat)
    if nt is None:
        m.warn("material '%s' does not use nodes: using Principled Volume defaults" % mat.name)
        return medium, "density", ""
    out = _output_node(nt)
    node = None
    if out is not None and "Volume" in out.inputs:
        node, _ = _follow(out.inputs["Volume"])
    if node is None or node.type != "PRINCIPLED_VOLUME":
        m.warn("material '%s': the Volume output is not fed by a Principled Volume node "
               "(%s): using Principled Volume defaults" % (mat.name, node.bl_idname if node else "nothing"))
        return medium, "density", ""
    inp = node.inputs

    def const(name, what=None):
        s = inp[name]
        if s.is_linked:
            m.warn("Principled Volume %s is linked to a node: vsd uses its own value" % (what or name))
        return s.default_value

    medium["density"] = max(0.0, float(const("Density")))
    medium["albedo"] = _clamp01(_color(const("Color")), "Principled Volume Color", m)
    g = float(const("Anisotropy"))
    medium["anisotropy"] = min(max(g, -0.999), 0.999)
    grid = inp["Density Attribute"].default_value if "Density Attribute" in inp else "density"
    absorb = _color(const("Absorption Color"))
    if max(absorb) > 0.0:
        m.warn("Principled Volume Absorption Color %s is not black: vsd treats it as black "
               "(extinction = Density, albedo = Color)" % [round(x, 3) for x in absorb])
    color_attr = inp["Color Attribute"].default_value if "Color Attribute" in inp else ""
    if color_attr and color_attr in grids:
        m.warn("Principled Volume Color Attribute '%s' is ignored (vsd's albedo is constant)" % color_attr)
    bb = float(const("Blackbody Intensity"))
    temp_attr = inp["Temperature Attribute"].default_value if "Temperature Attribute" in inp else ""
    if bb > 0.0 and temp_attr in grids:
        m.warn("Principled Volume blackbody emission (Temperature Attribute '%s') is not "
               "supported: ignored" % temp_attr)
    strength, egrid = _emission_strength(inp["Emission Strength"], m)
    ecol = _color(const("Emission Color"))
    if strength > 0.0 and not egrid:
        m.warn("Principled Volume Emission Strength %.3g without an Attribute node: vsd needs "
               "an emission grid (e.g. flame); emission ignored" % strength)
        strength = 0.0
    if egrid and grids and egrid not in grids:
        m.warn("emission grid '%s' is not in the volume file (grids: %s); emission ignored"
               % (egrid, ", ".join(grids)))
        egrid, strength = "", 0.0
    medium["emission_color"] = [max(0.0, x) for x in ecol]
    medium["emission_strength"] = max(0.0, strength)
    return medium, grid, (egrid if strength > 0.0 else "")


# ---- refractive index --------------------------------------------------------------------

def map_ior(settings, grids, medium, volume, m):
    """The add-on's index source (Scene.vsd.ior_source) -> medium.ior, medium.ior_from and
    volume.ior_grid, as docs/scene-file.md defines them. Returns True when the scene asks
    for refraction.

    * constant: medium.ior = IOR and nothing else (what the add-on always sent);
    * grid: volume.ior_grid = the grid of n, medium.ior_from = "none";
    * temperature: volume.ior_grid = the temperature grid ("temperature" when left empty),
      medium.ior_from = "temperature" (Gladstone-Dale: heat haze).
    A grid source sends medium.ior = 1: the renderer refuses ior_grid with medium.ior != 1.
    A grid the file lacks is still sent (the renderer's error names it and lists the
    file's grids) after a warning here, so an exported scene says so too."""
    src = settings.ior_source
    if src == "constant":
        medium["ior"] = float(settings.ior)
        return medium["ior"] != 1.0
    medium["ior"] = 1.0
    if src == "temperature":
        name = settings.ior_temperature_grid if settings.ior_temperature_grid.strip() else "temperature"
        medium["ior_from"] = "temperature"
    else:
        name = settings.ior_grid
        if not name.strip():
            m.warn("Index Source Grid without a grid name: no refraction (n = 1)")
            return False
        medium["ior_from"] = "none"
    volume["ior_grid"] = name
    if grids and name not in grids:
        m.warn("refractive index grid '%s' is not in the volume file (grids: %s)" % (name, ", ".join(grids)))
    return True


# ---- world -------------------------------------------------------------------------------

_env_cache = {}


def _export_image(img):
    """A packed or generated image -> a temporary float EXR (kept for the session, keyed by
    the image's name and content, so an animation sends one blob)."""
    w, h = img.size
    pix = [0.0] * (w * h * 4)
    img.pixels.foreach_get(pix)
    key = (img.name, w, h, hash(tuple(pix[::97])))
    path = _env_cache.get(key)
    if path and os.path.isfile(path):
        return path
    tmp = bpy.data.images.new("vsd_env_export", w, h, alpha=True, float_buffer=True)
    try:
        tmp.pixels.foreach_set(pix)
        fd, path = tempfile.mkstemp(prefix="vsd_env_", suffix=".exr")
        os.close(fd)
        tmp.filepath_raw = path
        tmp.file_format = "OPEN_EXR"
        tmp.save()
    finally:
        bpy.data.images.remove(tmp)
    _env_cache[key] = path
    return path


def map_world(scene, m):
    world = scene.world
    if world is None:
        m.warn("the scene has no world: black environment")
        return {"color": [0.0, 0.0, 0.0], "strength": 1.0}
    wnt = node_tree(world)
    if wnt is None:
        return {"color": [max(0.0, x) for x in _color(world.color)], "strength": 1.0}
    out = _output_node(wnt)
    node = None
    if out is not None and "Surface" in out.inputs:
        node, _ = _follow(out.inputs["Surface"])
    if node is None:
        m.warn("world '%s': nothing connected to Surface: black environment" % world.name)
        return {"color": [0.0, 0.0, 0.0], "strength": 1.0}
    if node.type != "BACKGROUND":
        m.warn("world '%s': Surface is fed by %s, not a Background node: grey environment"
               % (world.name, node.bl_idname))
        return {"color": [0.05, 0.05, 0.05], "strength": 1.0}
    env = {}
    ss = node.inputs["Strength"]
    if ss.is_linked:
        m.warn("world Background Strength is linked to a node: vsd uses its own value")
    env["strength"] = max(0.0, float(ss.default_value))
    cs = node.inputs["Color"]
    tex, _ = _follow(cs)
    if tex is None:
        if cs.is_linked:
            m.warn("world Background Color is linked to a muted or invalid node")
        env["color"] = [max(0.0, x) for x in _color(cs.default_value)]
        return env
    if tex.type != "TEX_ENVIRONMENT":
        m.warn("world Background Color is fed by %s: only an Environment Texture can be "
               "mapped; using the socket's colour" % tex.bl_idname)
        env["color"] = [max(0.0, x) for x in _color(cs.default_value)]
        return env
    img = tex.image
    if img is None:
        m.warn("world Environment Texture has no image: black environment")
        env["color"] = [0.0, 0.0, 0.0]
        return env
    if tex.projection != "EQUIRECTANGULAR":
        m.warn("Environment Texture projection %s: vsd reads it as equirectangular" % tex.projection)
    if img.packed_file is not None or img.source == "GENERATED":
        path = _export_image(img)
        m.warn("environment image '%s' is %s: sent as a temporary EXR"
               % (img.name, "packed" if img.packed_file is not None else "generated"))
    else:
        if img.source != "FILE":
            m.warn("environment image '%s' is a %s: its file is used as a still" % (img.name, img.source))
        path = os.path.normpath(bpy.path.abspath(img.filepath, library=img.library))
        if not os.path.isfile(path):
            raise MappingError("environment image '%s': file not found: %s" % (img.name, path))
    m.env_path = path
    env["file"] = path
    # the map is converted by the daemon (OpenColorIO) from its colour space to Blender's
    # working space, which the material and light colours are in and the passes come back in
    space = img.colorspace_settings.name
    working = colour.working_space()
    if colour.needs_conversion(space, working):
        env["colorspace"] = space
        env["working_space"] = working
    # Mapping node between Texture Coordinate and the Environment Texture: its Z rotation
    rot = 0.0
    vec, _ = _follow(tex.inputs["Vector"])
    if vec is not None:
        if vec.type == "MAPPING":
            if any(s.is_linked for s in vec.inputs[1:]):
                m.warn("world Mapping node inputs are linked: their values are ignored")
            r = vec.inputs["Rotation"].default_value
            if abs(r[0]) > 1e-6 or abs(r[1]) > 1e-6:
                m.warn("world Mapping rotation about X/Y is not supported: only Z is used")
            if "Location" in vec.inputs and vec.vector_type in ("POINT", "TEXTURE"):
                if any(abs(x) > 1e-6 for x in vec.inputs["Location"].default_value):
                    m.warn("world Mapping Location is ignored (has no effect on directions)")
            sc = vec.inputs["Scale"].default_value
            if any(abs(x - 1.0) > 1e-6 for x in sc):
                m.warn("world Mapping Scale %s is not supported: ignored" % list(sc))
            rot = float(r[2])
            if vec.vector_type == "TEXTURE":  # the inverse transform
                rot = -rot
            src, sock = _follow(vec.inputs["Vector"])
            if src is not None and not (src.type == "TEX_COORD" and sock.name == "Generated"):
                m.warn("world Mapping is fed by %s: vsd assumes Texture Coordinate > Generated"
                       % (src.bl_idname + "." + sock.name))
        elif vec.type != "TEX_COORD":
            m.warn("world Environment Texture Vector is fed by %s: ignored" % vec.bl_idname)
    env["rotation_z"] = rot
    # The node's interpolation: vsd has Blender's default Linear and Closest; Cubic and
    # Smart (cubic when magnified) come closest as Linear.
    interp = getattr(tex, "interpolation", "Linear")
    if interp == "Closest":
        env["interpolation"] = "closest"
    else:
        env["interpolation"] = "linear"
        if interp != "Linear":
            m.warn("world Environment Texture interpolation %s: vsd uses Linear" % interp)
    return env


# ---- camera and film ---------------------------------------------------------------------

def film_size(scene):
    r = scene.render
    return (max(1, int(r.resolution_x * r.resolution_percentage / 100)),
            max(1, int(r.resolution_y * r.resolution_percentage / 100)))


def _fit(cam, w, h):
    """('H' or 'V', sensor size in mm) the way Blender fits the sensor."""
    if cam.sensor_fit == "AUTO":
        return ("H" if w >= h else "V"), cam.sensor_width
    if cam.sensor_fit == "HORIZONTAL":
        return "H", cam.sensor_width
    return "V", cam.sensor_height


def larger_dim_extent(fit, extent_fit, w, h):
    """An extent given across the fitted dimension -> across the larger image dimension
    (vsd's fov and ortho_scale span the larger one, Blender's sensor fit Auto)."""
    if fit == "H":
        return extent_fit if w >= h else extent_fit * h / w
    return extent_fit if h >= w else extent_fit * w / h


def map_camera(cam_ob, w, h, m):
    if cam_ob is None:
        raise MappingError("the scene has no camera")
    cam = cam_ob.data
    mw = cam_ob.matrix_world
    out = {"matrix": [float(mw[r][c]) for r in range(4) for c in range(4)],
           "clip_start": float(cam.clip_start), "clip_end": float(max(cam.clip_end, cam.clip_start * 1.001))}
    fit, size = _fit(cam, w, h)
    if cam.type == "ORTHO":
        out["type"] = "orthographic"
        out["ortho_scale"] = float(larger_dim_extent(fit, cam.ortho_scale, w, h))
    else:
        if cam.type == "PANO":
            m.warn("panoramic cameras are not supported: rendered as perspective")
        elif cam.type != "PERSP":   # 5.0's CUSTOM (an OSL camera), and whatever comes next
            m.warn("camera type %s is not supported: rendered as perspective" % cam.type)
        t = size / 2.0 / cam.lens
        out["fov"] = float(2.0 * math.atan(larger_dim_extent(fit, t, w, h)))
    if abs(cam.shift_x) > 1e-6 or abs(cam.shift_y) > 1e-6:
        m.warn("camera shift is not supported: ignored")
    if cam.dof.use_dof:
        m.warn("camera depth of field is not supported: ignored")
    return out


# ---- lights -------------------------------------------------------------------------------

MAX_LIGHTS = 16


def _unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [float(x / n) for x in v] if n > 0 else [0.0, 0.0, -1.0]


def spot_has_cosine(version=None):
    """Whether this Blender's Cycles multiplies a spot's mask by the cosine to its axis: 3.x
    does, 4.2 and 5.0 do not (their light/spot.h; measured in docs/cycles-crosscheck.md,
    "Newer Cycles"). 4.0 and 4.1 were not measured and are taken as 4.2."""
    return tuple((version or bpy.app.version)[:2]) < (4, 0)


def map_light(light, mw, m):
    """One Blender light (data, matrix_world) as a lights[] entry, or None (with a note) for
    what vsd does not render. Cycles' units: a sun's Strength is W/m^2, a point's or spot's
    Power is watts; the light shines down its local -Z."""
    name = light.name
    color = [max(0.0, float(c)) for c in light.color]
    # 4.5's Exposure, Normalize and Temperature (light_units.py has the measured rules)
    scale = light_units.intensity_factor(light)
    tint = light_units.colour_factor(light)
    if tint is not None:
        if colour.working_space().lower() not in ("linear rec.709", "linear", "scene_linear"):
            m.warn("light '%s': its temperature colour is computed in Rec.709, not in the working "
                   "space %s" % (name, colour.working_space()))
        color = [max(0.0, c * t) for c, t in zip(color, tint)]
    direction = _unit([-mw[0][2], -mw[1][2], -mw[2][2]])
    position = [float(mw[0][3]), float(mw[1][3]), float(mw[2][3])]
    if getattr(light, "use_nodes", False):
        m.warn("light '%s': its node tree is not read (Color and Strength/Power are used)" % name)
    if light.type == "SUN":
        return {"type": "sun", "color": color, "strength": float(light.energy * scale), "direction": direction,
                "angle": float(min(max(light.angle, 0.0), 3.14159))}
    if light.type in ("POINT", "SPOT"):
        out = {"type": light.type.lower(), "color": color, "power": float(light.energy * scale), "position": position,
               "radius": float(max(light.shadow_soft_size, 0.0))}
        if light.type == "SPOT":
            sx, sy = mw.to_scale()[0], mw.to_scale()[1]
            if abs(sx - sy) > 1e-4 * max(abs(sx), abs(sy), 1e-9):
                m.warn("spot light '%s': a non-uniform scale (an elliptic cone) is rendered as a round cone" % name)
            out.update({"direction": direction, "spot_size": float(min(max(light.spot_size, 1e-4), math.pi)),
                        "spot_blend": float(min(max(light.spot_blend, 0.0), 1.0))})
            if not spot_has_cosine():
                out["spot_cosine"] = False
        return out
    m.warn("light '%s': %s lights are not supported: ignored" % (name, light.type.lower()))
    return None


def map_lights(depsgraph, method, refracts, m, viewport=False):
    """The scene's visible lights as lights[] (at most MAX_LIGHTS, the strongest first):
    a final render or an export leaves out lights disabled in renders (hide_render, also
    when the depsgraph is the viewport's, as the export's is), the viewport shows what it
    shows. A method that does not render lights, or a refracting medium, gets none, with a
    note: the renderer would refuse the scene."""
    found = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type != "LIGHT":
            continue
        if not viewport and ob.original.hide_render:
            continue
        entry = map_light(ob.data, inst.matrix_world, m)
        if entry is not None and max(entry["color"]) > 0 and entry.get("strength", entry.get("power", 0)) > 0:
            found.append(entry)
    if not found:
        return []
    # which methods render the scene's lights is vsd's to say (its method catalog)
    if method and not method_catalog.has(method, "scene_lights"):
        m.warn("method %s does not render lights: %d ignored (%s render them)"
               % (method_catalog.label(method), len(found), method_catalog.labels_with("scene_lights")))
        return []
    if refracts:
        m.warn("lights through a refracting medium are not supported: %d ignored (the environment lights it)"
               % len(found))
        return []
    if len(found) > MAX_LIGHTS:
        # a sun's W/m^2 and a lamp's W are not comparable: suns first, then lamps by power
        found.sort(key=lambda e: (e["type"] != "sun", -e.get("strength", e.get("power", 0)) * max(e["color"])))
        m.warn("%d lights: the %d strongest are rendered" % (len(found), MAX_LIGHTS))
        found = found[:MAX_LIGHTS]
    return found


# ---- the whole scene ---------------------------------------------------------------------

def render_block(settings, viewport=False, method=None):
    """The scene's render section from the add-on's settings (Scene.vsd); `method` replaces
    the menu's choice (the viewport's fallback for several volumes)."""
    import json
    if method is None:
        method = method_catalog.chosen_for(settings, viewport)
    # the options set away from vsd's defaults, by its own table (method_catalog.py)
    opts = method_catalog.values(settings.id_data, method)
    text = settings.options_json.strip()
    if text:
        try:
            extra = json.loads(text)
        except ValueError as e:
            raise MappingError("vsd render options: not JSON: %s" % e)
        if not isinstance(extra, dict):
            raise MappingError("vsd render options: expected a JSON object like {\"lights\": 64}")
        opts.update(extra)
    r = {"device": settings.device,
         "samples": int(settings.viewport_samples if viewport else settings.samples),
         "seed": int(settings.seed), "options": opts}
    if method:   # else no catalog was loaded: the daemon's default method
        r["method"] = method
    if settings.threads > 0:
        r["threads"] = int(settings.threads)
    return r


SEVERAL = method_catalog.SEVERAL   # the capability of the methods that render several volumes


def method_for_volumes(chosen, count, viewport, export, m):
    """The method that renders `count` volumes, as the catalog says (no method is named
    here): `chosen` when it can, or when there is one volume; else the viewport falls back
    to method_catalog.viewport_fallback() (with a note in its status), an
    export keeps `chosen` with a warning (`vsd render` would refuse it), and F12 is an
    error naming the method and those that can."""
    if count <= 1 or not chosen or method_catalog.has(chosen, SEVERAL):
        return chosen
    can = method_catalog.with_capability(SEVERAL)
    which = ("%s render several" % method_catalog.labels_with(SEVERAL)) if can else \
        "no method of this vsd renders several"
    if viewport:
        fallback = method_catalog.viewport_fallback()
        if not fallback:
            raise MappingError("%s renders one volume and %s: hide all volumes but one"
                               % (method_catalog.label(chosen), which))
        m.fallback_from = chosen
        # first, so the preview's overlay (its first few notes) always shows it
        m.warnings.insert(0, "%s renders one volume; showing %s for %d volumes"
                          % (method_catalog.label(chosen), method_catalog.label(fallback), count))
        return fallback
    if export:
        m.warn("method %s renders one volume and the scene has %d: `vsd render` refuses it as it is (%s; "
               "pick one with --method%s)" % (method_catalog.label(chosen), count, which,
                                             (" " + can[0]) if can else ""))
        return chosen
    raise MappingError("method %s renders one volume and the scene has %d volumes (%s: pick one in "
                       "Render Properties > vsd > Method, or hide all volumes but one)"
                       % (method_catalog.label(chosen), count, which))


def map_volumes(obs, frame, settings, m):
    """The volumes[] entries (each with its medium) of objects `obs`, and whether the scene
    asks for refraction. A sequence showing no file at this frame is left out (with a note)
    when another volume is shown; alone it is the error it always was."""
    out = []
    skipped = []
    for ob in obs:
        try:
            entry, path, pattern = map_volume(ob, frame, m)
        except NoFileAtFrame as e:
            if len(obs) == 1:
                raise
            skipped.append(str(e))
            continue
        try:
            grids = [g.name for g in ob.data.grids]
        except Exception:
            grids = []
        medium, grid, egrid = map_material(ob, grids, m)
        k = object_space_density(ob)
        medium["density"] *= k
        medium["emission_strength"] *= k
        entry["grid"] = grid
        entry["matrix"] = voxel_centre_matrix(ob, grid, m)   # loads the grids
        if egrid:
            entry["emission_grid"] = egrid
        entry["medium"] = medium
        out.append(VolumeMap(ob, entry, path, pattern))
    if not out:
        raise NoFileAtFrame("; ".join(skipped))
    for note in skipped:
        m.warn(note + ": not rendered at this frame")
    # vsd's own settings (Blender's volumes do not refract): the refractive index, for a
    # scene of one volume (vsd refuses refraction with several so far)
    refracts = False
    if len(out) == 1:
        ob = out[0].object
        try:
            grids = [g.name for g in ob.data.grids]
        except Exception:
            grids = []
        refracts = map_ior(settings, grids, out[0].entry["medium"], out[0].entry, m)
    elif settings.ior_source != "constant" or settings.ior != 1.0:
        m.warn("the refractive index (vsd > Index Source) is ignored: vsd refracts a scene of one volume "
               "only, this one has %d" % len(out))
    return out, refracts


def build_scene(depsgraph, camera=None, size=None, viewport=False, export=False):
    """Map the evaluated scene to a vsd scene dict (local file paths): every volume object
    the view layer renders as an entry of `volumes` (volume_objects). `camera` overrides
    the scene camera, `size` the film size; `viewport`: the rendered viewport's mapping
    (what it shows, no camera, its method), `export`: File > Export's (a method that renders
    one volume is a warning there, an error for F12). Raises MappingError when there is
    nothing renderable."""
    m = Mapping()
    scene = depsgraph.scene
    frame = scene.frame_current
    obs = pick_volumes(depsgraph, m, final=not viewport)
    m.volumes, refracts = map_volumes(obs, frame, scene.vsd, m)
    method = method_for_volumes(method_catalog.chosen_for(scene.vsd, viewport), len(m.volumes),
                                viewport, export, m)
    m.method = method
    if refracts and not viewport and method and not method_catalog.has(method, "refraction"):
        m.warn("method %s ignores the refractive index: only %s refract"
               % (method_catalog.label(method), method_catalog.labels_with("refraction")))
    w, h = size if size else film_size(scene)
    r = scene.render
    if not viewport:
        if abs(r.pixel_aspect_x - r.pixel_aspect_y) > 1e-6:
            m.warn("non-square pixel aspect is not supported: square pixels rendered")
        if r.use_border:
            m.warn("render region (border) is not supported: the whole frame is rendered")
        if r.use_motion_blur:
            m.warn("motion blur is not supported: ignored")
    cam_ob = camera if camera is not None else scene.camera
    if cam_ob is not None and not viewport:
        cam_ob = cam_ob.evaluated_get(depsgraph)
    sc = {
        "version": 1,
        "volumes": [v.entry for v in m.volumes],
        "environment": map_world(scene, m),
        "lights": map_lights(depsgraph, method, refracts, m, viewport),
        "camera": map_camera(cam_ob, w, h, m) if not viewport else {},
        "film": {"width": int(w), "height": int(h), "transparent": bool(r.film_transparent)},
        "render": render_block(scene.vsd, viewport, method),
        "frames": {"start": int(frame), "end": int(frame)},
        # the add-on reads each result at once: RLE, not ZIP. At 1280x720 on 2 cores ZIP's encode
        # takes 0.34 s; RLE's 0.07 s halves the bytes that "none" sends (the empty background),
        # and the Python client's wall over the render fell from 0.23 s (none) to 0.10 s.
        "output": {"passes": list(passes.VSD_PASS_NAMES), "layer": depsgraph.view_layer.name,
                   "pass_names": passes.pass_names(bpy.app.version), "compression": "rle"},
    }
    m.scene = sc
    return m
