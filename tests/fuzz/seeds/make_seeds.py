#!/usr/bin/env python3
"""Writes the hand-made seeds of tests/fuzz/corpus/{scene,protocol,daemon} (make_seeds.sh
calls it after the .vdb and map seeds exist: the daemon seeds PUT two of them as blobs).
Frames follow docs/protocol.md: "VSDP", u16 version, u16 type, u32 JSON length, u64 binary
length, big-endian, then the JSON and binary parts."""
import hashlib, json, os, struct, sys

root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "corpus")
HELLO, HAS, PUT, RENDER, PROGRESS, RESULT, ERROR, CANCEL, STATS, BYE = range(1, 11)


def frame(t, obj, binary=b"", version=1, magic=b"VSDP", json_text=None):
    j = json_text if json_text is not None else json.dumps(obj, separators=(",", ":")).encode()
    return magic + struct.pack(">HHIQ", version, t, len(j), len(binary)) + j + binary


def write(sub, name, data):
    d = os.path.join(root, sub)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


# ---- scene: JSON text, then NUL-separated overrides ----------------------------------------
full = open(os.path.join(os.path.dirname(__file__), "..", "..", "data", "scenes", "full.json"), "rb").read()
write("scene", "full.json", full)
write("scene", "full_overrides", full + b"\0film.width=32\0render.options={\"lights\":4}\0"
      b"camera.matrix=[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]\0frames.end=3")
small = {
    "version": 1,
    "volume": {"file": "smoke_####.vdb", "grid": "density", "emission_grid": "flame", "ior_grid": "temperature"},
    "medium": {"density": 10.0, "albedo": [0.9, 0.9, 0.9], "anisotropy": 0.3, "emission_color": [1, 0.5, 0.1],
               "emission_strength": 1.0, "ior": 1.2, "ior_from": "temperature"},
    "environment": {"file": "sunset.exr", "strength": 1.0, "rotation_z": 0.5, "colorspace": "Linear Rec.709"},
    "camera": {"position": [0, -6, 1], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 0.69, "type": "orthographic",
               "ortho_scale": 3.0},
    "film": {"width": 64, "height": 36, "transparent": False},
    "render": {"method": "raymarch", "device": "cpu", "samples": 4, "seed": 7, "options": {"step": 0.5}},
    "frames": {"start": 2, "end": 9},
    "output": {"exr": "/abs/out_####.exr", "passes": ["Combined", "Depth"], "half": True,
               "pass_names": {"VolumeDir": "Volume Direct"}, "preview_png": "p.png"},
}
write("scene", "small.json", json.dumps(small, indent=1).encode())
write("scene", "minimal.json", b'{"version":1,"volume":{"file":"a.vdb"}}')
write("scene", "env_color", b'{"version":1,"volume":{"file":"a.vdb","matrix":[2,0,0,1,0,2,0,1,0,0,2,1,0,0,0,1]},'
      b'"environment":{"color":[0.1,0.2,0.3]},"lights":[]}\0environment.strength=2\0volume.grid="heat"')
write("scene", "bom_comment", b'\xef\xbb\xbf{"version":1,"volume":{"file":"x_#.vdb"},"frames":{"start":-3,"end":-1}}')
for name in ("cloud128_interior.json", "fire96_studio.json"):
    p = os.path.join(os.environ.get("VSD_SHARED_DATA", os.path.join(os.path.dirname(__file__), "..", "..", "..", "..", "shared", "data")), "scenes", name)
    if os.path.exists(p):
        write("scene", name, open(p, "rb").read())

# ---- protocol: single frames ----------------------------------------------------------------
write("protocol", "hello", frame(HELLO, {"id": 1, "versions": [1], "client": "fuzz"}))
write("protocol", "has", frame(HAS, {"id": 2, "hashes": ["0" * 32, "a" * 64, "xyz"]}))
write("protocol", "put", frame(PUT, {"id": 3, "hash": "0" * 32}, b"blob"))
write("protocol", "render", frame(RENDER, {"id": 4, "scene": {"version": 1}}))
write("protocol", "bad_magic", frame(STATS, {}, magic=b"VSDQ"))
write("protocol", "truncated", frame(CANCEL, {"id": 5, "job": 4})[:27])

# ---- daemon: byte 0 = flags (bit 0: TCP connection), then the client's stream -----------------
vdb = open(os.path.join(root, "vdb", "ball_zip.vdb"), "rb").read()
hdr = open(os.path.join(root, "env", "stinson4.hdr"), "rb").read()
hv, he = hashlib.sha256(vdb).hexdigest(), hashlib.sha256(hdr).hexdigest()
hello = frame(HELLO, {"id": 1, "versions": [1], "client": "fuzz"})
scene = {"version": 1, "volume": {"file": "blob:" + hv, "grid": "density"},
         "environment": {"file": "blob:" + he, "strength": 1.5},
         "camera": {"position": [0.4, -2, 0.4], "look_at": [0.4, 0.4, 0.4], "fov": 0.7},
         "film": {"width": 8, "height": 6}, "render": {"method": "raymarch", "samples": 1}, "medium": {"density": 5}}
write("daemon", "hello_stats_bye", b"\0" + hello + frame(STATS, {"id": 2}) + frame(BYE, {"id": 3}))
write("daemon", "put_render", b"\0" + hello + frame(HAS, {"id": 2, "hashes": [hv, he]}) +
      frame(PUT, {"id": 3, "hash": hv}, vdb) + frame(PUT, {"id": 4, "hash": he}, hdr) +
      frame(RENDER, {"id": 10, "scene": scene, "preview": True}) + frame(STATS, {"id": 11}))
write("daemon", "render_string_overrides", b"\0" + hello + frame(PUT, {"id": 3, "hash": hv}, vdb) +
      frame(RENDER, {"id": 12, "scene": json.dumps({k: v for k, v in scene.items() if k != "environment"}),
                     "overrides": ["film.width=4", "render.method=\"reference\"", "medium.albedo=[1,0,0]"],
                     "frame": 3}) + frame(CANCEL, {"id": 13, "job": 12}))
write("daemon", "render_missing", b"\0" + hello + frame(RENDER, {"id": 20, "scene": scene}) +
      frame(RENDER, {"id": 20, "scene": {"version": 1}}) + frame(CANCEL, {"id": 21, "job": 20}))
write("daemon", "server_paths", b"\0" + hello + frame(RENDER, {"id": 30, "scene": {
      "version": 1, "volume": {"file": "not_a.vdb"}, "environment": {"file": "map.hdr"}, "film": {"width": 8, "height": 8}}}) +
      frame(RENDER, {"id": 31, "scene": {"version": 1, "volume": {"file": "../../etc/passwd"}}}) +
      frame(RENDER, {"id": 32, "scene": {"version": 1, "volume": {"file": "blob:" + hv},
                                          "environment": {"file": "empty.hdr"}, "film": {"width": 4000}}}))
write("daemon", "tcp_token", b"\1" + frame(HELLO, {"id": 1, "token": "fuzz-token-0123"}) + frame(STATS, {"id": 2}))
write("daemon", "tcp_no_token", b"\1" + frame(STATS, {"id": 1}) + frame(HELLO, {"id": 2}))
write("daemon", "put_mismatch", b"\0" + hello + frame(PUT, {"id": 3, "hash": "0" * 32}, b"abc") +
      frame(PUT, {"id": 4, "hash": "XYZ"}, b"abc") + frame(PUT, {"id": 5}, b"") + frame(HAS, {"id": 6, "hashes": "no"}))
write("daemon", "errors", b"\0" + frame(STATS, {"id": 1}) + frame(77, {"id": 2}) + frame(HELLO, {"id": "x"}) +
      frame(HELLO, {}, json_text=b"[1,2") + frame(HELLO, {"versions": [2]}) + hello +
      frame(CANCEL, {"id": 3}) + frame(STATS, {}, version=2))
write("daemon", "too_large", b"\0" + hello + b"VSDP" + struct.pack(">HHIQ", 1, HAS, 1 << 30, 0))
write("daemon", "bin_not_put", b"\0" + hello + frame(STATS, {"id": 2}, b"xx"))
