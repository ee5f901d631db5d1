# Shared by the add-on tests (tests/blender_addon/test_*.py), which run inside real Blender:
#
#   blender --background --factory-startup --python-exit-code 1 \
#       --python tests/blender_addon/test_X.py -- VSD SHARED_DATA TMP_DIR
#
# * install_addon(): builds the zip with plugin_blender/make_zip.py, unpacks it into a temp
#   scripts folder and enables `vsd_blender` from there with addon_utils (so the packaging
#   is tested too, and the user's Blender configuration is never touched);
# * start_test(): the arguments, a fresh TMP_DIR and the add-on installed: how a test begins;
# * Daemon: `vsd serve` on a temp socket with --ready-file, stopped with SIGTERM;
#   addon_daemon(): one the add-on uses for a `with` block, with the checks tests end on;
# * build_scene(): a smoke64 Volume sequence + studio.exr world + camera, from ../shared/data;
# * read_exr(): a small stdlib-only OpenEXR reader (scanline, NONE/ZIPS/ZIP, HALF/FLOAT)
#   for comparing pixels (Blender's Python has no numpy here).
import contextlib
import json
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import time
import zlib

import bpy
import mathutils

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
failures = []
# The add-on's module name: "vsd_blender" as a legacy add-on (3.4, and 4.2+ from the zip),
# "bl_ext.<repository>.vsd_blender" as an extension (4.2+). install_addon() sets it.
ADDON = "vsd_blender"
# True under a `bpy` wheel (tests/blender_addon/blender_wheel.py), False in a Blender binary.
IS_WHEEL = not bpy.app.binary_path


def addon_module(name):
    """The add-on's submodule `name` ("mapping", "passes", ...) as Blender loaded it."""
    import importlib
    return importlib.import_module("%s.%s" % (ADDON, name))   # viewport loads lazily


def blender_pass(vsd_name):
    """The name this Blender gives vsd's pass `vsd_name` (5.0: "Volume Direct", ...), from
    the add-on's table, which test_versions checks against this version's own Cycles."""
    return addon_module("passes").pass_names(bpy.app.version)[vsd_name]


def addon_prefs():
    return bpy.context.preferences.addons[ADDON].preferences


# ---- what differs between Blender versions, for the tests' own scene building -------------

def use_nodes(idblock):
    """Material/World/Light use_nodes = True where it still means something: 5.0 deprecated
    it (always on, removal planned for 6.0)."""
    if bpy.app.version < (5, 0, 0):
        idblock.use_nodes = True
    return idblock.node_tree


def empty_node_tree(idblock):
    """The node tree of a new Material or World, with its default nodes removed so that a
    test builds exactly the nodes it means."""
    nt = use_nodes(idblock)
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    return nt


def compositor_tree(scene):
    """The scene's compositing node tree: scene.node_tree up to 4.5, 5.0's node group."""
    if hasattr(scene, "compositing_node_group"):
        if scene.compositing_node_group is None:
            scene.compositing_node_group = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
        return scene.compositing_node_group
    scene.use_nodes = True
    return scene.node_tree


def set_multilayer_exr(image_settings):
    """Multilayer EXR output: 5.0 moved it under media_type."""
    if hasattr(image_settings, "media_type"):
        image_settings.media_type = "MULTI_LAYER_IMAGE"
    image_settings.file_format = "OPEN_EXR_MULTILAYER"


def args():
    argv = sys.argv[sys.argv.index("--") + 1:]
    vsd, data, tmp = os.path.abspath(argv[0]), os.path.abspath(argv[1]), os.path.abspath(argv[2])
    return vsd, data, tmp, argv[3:]


def check(cond, what):
    print(("ok:   " if cond else "FAIL: ") + what, flush=True)
    if not cond:
        failures.append(what)


def finish(name):
    if failures:
        print("%s: %d check(s) failed: %s" % (name, len(failures), "; ".join(failures)), flush=True)
        sys.stdout.flush()
        os._exit(1)
    print("%s: all checks passed" % name, flush=True)


def fresh_tmp(tmp):
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)


def install_addon(tmp, vsd=None, auto_start=False, address="", by_copy=False):
    """Package the add-on, unpack it into tmp/scripts/addons and enable it; by_copy: copy
    the repository's plugin_blender/vsd_blender folder there instead, as a developer does."""
    import addon_utils
    import zipfile
    addons = os.path.join(tmp, "scripts", "addons")
    os.makedirs(addons, exist_ok=True)
    if by_copy:
        shutil.copytree(os.path.join(REPO, "plugin_blender", "vsd_blender"), os.path.join(addons, "vsd_blender"),
                        ignore=shutil.ignore_patterns("__pycache__"))
    else:
        zpath = os.path.join(tmp, "vsd_blender.zip")
        subprocess.run([sys.executable if os.path.basename(sys.executable).startswith("python") else "python3",
                        os.path.join(REPO, "plugin_blender", "make_zip.py"), zpath], check=True)
        with zipfile.ZipFile(zpath) as z:
            z.extractall(addons)
    if addons not in sys.path:
        sys.path.insert(0, addons)
    global ADDON
    ADDON = "vsd_blender"
    mod = addon_utils.enable(ADDON, default_set=True, handle_error=None)
    assert mod is not None, "addon_utils.enable(vsd_blender) failed"
    assert os.path.dirname(mod.__file__) == os.path.join(addons, "vsd_blender"), mod.__file__
    prefs = addon_prefs()
    prefs.vsd_path = vsd or ""
    prefs.auto_start = auto_start
    prefs.address = address
    return mod


def start_test():
    """How an add-on test begins: its arguments (VSD, SHARED_DATA, TMP_DIR), TMP_DIR emptied
    and the add-on installed there with vsd_path set; returns (vsd, data, tmp)."""
    vsd, data, tmp, _ = args()
    fresh_tmp(tmp)
    install_addon(tmp, vsd=vsd)
    return vsd, data, tmp


class Daemon(object):
    def __init__(self, vsd, tmp, name="d", extra=()):
        self.sock = os.path.join(tmp, name + ".sock")
        self.ready = os.path.join(tmp, name + ".ready.json")
        self.logpath = os.path.join(tmp, name + ".log")
        self.log = open(self.logpath, "w")
        cache = os.path.join(tmp, name + ".cache")
        os.makedirs(cache, exist_ok=True)
        self.proc = subprocess.Popen([vsd, "serve", "--socket", self.sock, "--ready-file", self.ready,
                                      "--cache-dir", cache, "--log-level", "info"] + list(extra),
                                     stdout=self.log, stderr=self.log)
        for _ in range(300):
            if os.path.exists(self.ready):
                break
            time.sleep(0.05)
        assert os.path.exists(self.ready), "the daemon did not start (see %s)" % self.logpath

    def alive(self):
        return self.proc.poll() is None

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        self.log.close()
        return self.proc.returncode


@contextlib.contextmanager
def addon_daemon(vsd, tmp):
    """A Daemon that the add-on renders with (its address in the add-on's preferences) for
    the `with` block. When the block ends normally, checks that the daemon survived it;
    however it ends, stops the daemon, and then (unless the block raised) checks that it
    exited 0 on SIGTERM."""
    d = Daemon(vsd, tmp)
    try:
        addon_prefs().address = d.sock
        yield d
        check(d.alive(), "daemon still serving")
    finally:
        rc = d.stop()
    check(rc == 0, "daemon exits 0 on SIGTERM")


# ---- the Blender scene -------------------------------------------------------------------

def clear_scene():
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.lights, bpy.data.cameras, bpy.data.materials,
                 bpy.data.volumes, bpy.data.worlds):
        for item in list(coll):
            coll.remove(item)


def look_at_matrix(pos, target):
    pos = mathutils.Vector(pos)
    d = mathutils.Vector(target) - pos
    rot = d.to_track_quat("-Z", "Y").to_matrix().to_4x4()
    return mathutils.Matrix.Translation(pos) @ rot


def build_scene(data, width=64, height=36, percentage=100, grid="density", frame_start=1, frame_offset=0,
                rotation_deg=30.0, strength=1.2, transparent=True, density=8.0, color=(0.8, 0.75, 0.7),
                anisotropy=0.2, cam_pos=(1.0, -3.9745, 1.8771), cam_target=(1.0, 1.0, 1.0), lens=40.0):
    """smoke64 as a Volume sequence (scene frame_start shows file 1 + frame_offset), its Principled
    Volume, studio.exr through a Mapping Z rotation, and a camera looking at the plume."""
    scene = bpy.context.scene
    clear_scene()
    vol = bpy.data.volumes.new("smoke")
    vol.filepath = os.path.join(data, "smoke64", "fluid_data_0001.vdb")
    vol.is_sequence = True
    vol.frame_start = frame_start
    vol.frame_duration = 30
    vol.frame_offset = frame_offset
    vol.sequence_mode = "CLIP"
    ob = bpy.data.objects.new("smoke", vol)
    scene.collection.objects.link(ob)
    ob.matrix_world = mathutils.Matrix.Translation((0.1, 0.0, -0.05))

    mat = bpy.data.materials.new("smoke_mat")
    nt = empty_node_tree(mat)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Density"].default_value = density
    pv.inputs["Color"].default_value = tuple(color) + (1.0,)
    pv.inputs["Anisotropy"].default_value = anisotropy
    pv.inputs["Density Attribute"].default_value = grid
    nt.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    ob.data.materials.append(mat)

    world = bpy.data.worlds.new("studio")
    scene.world = world
    wn = empty_node_tree(world)
    wo = wn.nodes.new("ShaderNodeOutputWorld")
    bg = wn.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = strength
    tc = wn.nodes.new("ShaderNodeTexCoord")
    mp = wn.nodes.new("ShaderNodeMapping")
    mp.vector_type = "POINT"
    mp.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_deg))
    tex = wn.nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(os.path.join(data, "env", "studio.exr"), check_existing=True)
    wn.links.new(tc.outputs["Generated"], mp.inputs["Vector"])
    wn.links.new(mp.outputs["Vector"], tex.inputs["Vector"])
    wn.links.new(tex.outputs["Color"], bg.inputs["Color"])
    wn.links.new(bg.outputs["Background"], wo.inputs["Surface"])

    cam = bpy.data.cameras.new("cam")
    cam.lens = lens
    cam.sensor_fit = "AUTO"
    cob = bpy.data.objects.new("cam", cam)
    scene.collection.objects.link(cob)
    cob.matrix_world = look_at_matrix(cam_pos, cam_target)
    scene.camera = cob

    r = scene.render
    r.engine = "VSD"
    r.resolution_x = width
    r.resolution_y = height
    r.resolution_percentage = percentage
    r.film_transparent = transparent
    r.use_compositing = False
    r.use_sequencer = False
    set_multilayer_exr(r.image_settings)
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    scene.view_settings.view_transform = "Standard"
    scene.frame_start = frame_start
    scene.frame_end = frame_start + 2
    scene.frame_set(frame_start)
    s = scene.vsd
    s.method = "raymarch"
    scene.vsd_options.raymarch.lights = 8   # a row of the table vsd sent (method_catalog.py)
    s.samples = 1
    s.device = "cpu"
    return scene, ob


# ---- EXR reading -------------------------------------------------------------------------

def _half(h):
    return struct.unpack("<e", struct.pack("<H", h))[0]


def _read_header(data, pos):
    """One header's attributes {name: (type, bytes)} from `pos`; returns it and the position
    after its terminating null."""
    header = {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        pos = end + 1
        end = data.index(b"\0", pos)
        typ = data[pos:end].decode()
        pos = end + 1
        size = struct.unpack_from("<i", data, pos)[0]
        pos += 4
        header[name] = (typ, data[pos:pos + size])
        pos += size
    return header, pos + 1


def _channels(header):
    chans, raw, p = [], header["channels"][1], 0
    while raw[p] != 0:
        end = raw.index(b"\0", p)
        chans.append((raw[p:end].decode(), struct.unpack_from("<i", raw, end + 1)[0]))
        p = end + 1 + 16
    return chans


def _unrle(block):
    """EXR's RLE: a signed count byte, then -count literal bytes or count + 1 repeats of one."""
    out, i = bytearray(), 0
    while i < len(block):
        n = struct.unpack_from("b", block, i)[0]
        i += 1
        if n < 0:
            out += block[i:i - n]
            i -= n
        else:
            out += block[i:i + 1] * (n + 1)
            i += 1
    return out


def read_exr(path):
    """{channel name: list of floats, row-major, top row first}, width, height.
    Scanline files with NONE, RLE, ZIPS or ZIP compression (what vsd and Blender write here),
    single-part (3.4-4.5, vsd) or multi-part (Blender 5.0 writes a part per pass)."""
    with open(path, "rb") as f:
        return read_exr_bytes(f.read(), path)


def read_exr_bytes(data, path="EXR"):
    """read_exr of a file's bytes (a RESULT's EXR as the daemon sent it)."""
    assert data[:4] == b"\x76\x2f\x31\x01", path + ": not an EXR"
    flags = struct.unpack_from("<I", data, 4)[0]
    assert not (flags & 0x200), path + ": tiled EXR not supported by this reader"
    multipart = bool(flags & 0x1000)
    pos, headers = 8, []
    while True:
        header, pos = _read_header(data, pos)
        headers.append(header)
        if not multipart or data[pos] == 0:
            break
    if multipart:
        pos += 1  # the empty header that ends the list
    out, size_wh = {}, None
    for part, header in enumerate(headers):
        chans = _channels(header)
        xmin, ymin, xmax, ymax = struct.unpack("<4i", header["dataWindow"][1])
        w, h = xmax - xmin + 1, ymax - ymin + 1
        size_wh = size_wh or (w, h)
        comp = header["compression"][1][0]
        assert comp in (0, 1, 2, 3), "%s: compression %d not supported by this reader" % (path, comp)
        lines = {0: 1, 1: 1, 2: 1, 3: 16}[comp]
        nblocks = (h + lines - 1) // lines
        offsets = struct.unpack_from("<%dQ" % nblocks, data, pos)
        pos += 8 * nblocks
        for c, _ in chans:
            out[c] = [0.0] * (w * h)
        for off in offsets:
            if multipart:
                off += 4  # the chunk's part number
            y, size = struct.unpack_from("<ii", data, off)
            block = data[off + 8:off + 8 + size]
            nl = min(lines, ymax - y + 1)
            expected = sum(nl * w * (2 if t == 1 else 4) for _, t in chans)
            if comp != 0 and size < expected:
                t = _unrle(block) if comp == 1 else bytearray(zlib.decompress(block))
                for i in range(1, len(t)):
                    t[i] = (t[i - 1] + t[i] - 128) & 0xFF
                half = (len(t) + 1) // 2
                u = bytearray(len(t))
                u[0::2] = t[:half]
                u[1::2] = t[half:]
                block = bytes(u)
            q = 0
            for li in range(nl):
                row = y - ymin + li
                for cname, ptype in chans:
                    if ptype == 1:
                        vals = [_half(v) for v in struct.unpack_from("<%dH" % w, block, q)]
                        q += 2 * w
                    else:
                        vals = struct.unpack_from("<%df" % w, block, q)
                        q += 4 * w
                    out[cname][row * w:(row + 1) * w] = vals
    return out, size_wh[0], size_wh[1]


def run_blender_render(write_path=None, animation=False):
    """bpy.ops.render.render; returns the error message Blender raised (None if none)."""
    scene = bpy.context.scene
    if write_path:
        scene.render.filepath = write_path
        scene.render.use_file_extension = False
    try:
        if animation:
            bpy.ops.render.render(animation=True)
        else:
            bpy.ops.render.render(write_still=bool(write_path))
    except RuntimeError as e:
        return str(e)
    return None


def export_and_render(vsd, tmp, name):
    """File > Export > vsd scene (current frame) to TMP/export/NAME.json, checked to finish,
    then `vsd render` of the export. Returns (the exported scene dict, the render's
    CompletedProcess)."""
    scene_json = os.path.join(tmp, "export", name + ".json")
    os.makedirs(os.path.dirname(scene_json), exist_ok=True)
    res = bpy.ops.export_scene.vsd(filepath=scene_json, frame_range=False)
    check(res == {"FINISHED"}, "export operator finished (%s)" % res)
    with open(scene_json) as f:
        ex = json.load(f)
    r = subprocess.run([vsd, "render", scene_json, "--output", os.path.join(tmp, name + "_cli_####.exr"), "--quiet"],
                       capture_output=True, text=True)
    return ex, r


def vsd_stats(sock):
    sys.path.insert(0, os.path.join(REPO, "plugin_blender", "vsd_blender"))
    import vsd_client
    with vsd_client.Client(sock) as c:
        return c.stats()


class LayoutRecorder(object):
    """Stands in for a panel's layout and records the rows drawn: ("prop", data, key),
    ("search", data, key, search_data, search_key), ("label", None, text); the keys of
    props drawn in a row set inactive (greyed out) also go to `inactive`."""

    def __init__(self, rows=None, inactive=None):
        self.rows = rows if rows is not None else []
        self.inactive = inactive if inactive is not None else []
        self.active = True
        self.use_property_split = self.use_property_decorate = False

    def column(self, **kw):
        return self

    def row(self, **kw):
        child = LayoutRecorder(self.rows, self.inactive)
        child.active = self.active
        return child

    def prop(self, data, key, **kw):
        self.rows.append(("prop", data, key))
        if not self.active:
            self.inactive.append(key)

    def prop_search(self, data, key, search_data, search_key, **kw):
        self.rows.append(("search", data, key, search_data, search_key))

    def label(self, **kw):
        self.rows.append(("label", None, kw.get("text")))


class FakePanel(object):
    """What a Panel.draw needs of self: a layout (a LayoutRecorder)."""

    def __init__(self):
        self.layout = LayoutRecorder()
