"""vsd_client — a pure-Python (stdlib only) client of the vsd render daemon, protocol v1.

Blender's Python has nothing beyond the standard library, so this module uses only
socket, struct, json and hashlib. Blobs are named by SHA-256 (hashlib); the daemon
accepts both SHA-256 and XXH3-128 names (docs/protocol.md).

    from vsd_client import Client
    with Client() as c:                          # default socket, or Client("/path.sock"),
        name = c.upload_file("smoke_0001.vdb")   # Client("127.0.0.1:7878", token="...")
        res = c.render(scene_dict, frame=1, progress=lambda stage, f: print(stage, f))
        open("out.exr", "wb").write(res.exr)

Errors from the daemon raise VsdError with .code (a stable string, e.g. "busy",
"missing_blob", "cancelled") and .info (the whole ERROR message as a dict).
"""
import hashlib
import json
import os
import socket
import struct
import threading
import time

PROTOCOL_VERSION = 1
MAGIC = b"VSDP"
HEADER = struct.Struct(">4sHHIQ")  # magic, version, type, json length, binary length

HELLO, HAS, PUT, RENDER, PROGRESS, RESULT, ERROR, CANCEL, STATS, BYE = range(1, 11)
TYPE_NAMES = {HELLO: "HELLO", HAS: "HAS", PUT: "PUT", RENDER: "RENDER", PROGRESS: "PROGRESS",
              RESULT: "RESULT", ERROR: "ERROR", CANCEL: "CANCEL", STATS: "STATS", BYE: "BYE"}

MAX_REPLY_JSON = 64 << 20


class VsdError(Exception):
    """The daemon answered ERROR (code set) or the connection failed (code "connection")."""

    def __init__(self, code, message, info=None):
        super().__init__("%s: %s" % (code, message))
        self.code = code
        self.message = message
        self.info = info or {}


class Result(object):
    """A finished render: EXR bytes, optional preview PNG bytes, and the RESULT message."""

    def __init__(self, info, exr, png):
        self.info = info
        self.exr = exr
        self.png = png

    @property
    def timings(self):
        return self.info.get("timings", {})

    @property
    def cache(self):
        return self.info.get("cache", {})


def default_socket():
    xdg = os.environ.get("XDG_RUNTIME_DIR")
    if xdg:
        return os.path.join(xdg, "vsd.sock")
    return "/tmp/vsd-%d.sock" % os.getuid()


def hash_file(path, chunk=1 << 20):
    """SHA-256 of a file as 64 lowercase hex digits (a blob name without "blob:")."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(chunk)
            if not b:
                break
            h.update(b)
    return h.hexdigest()


def hash_bytes(data):
    return hashlib.sha256(data).hexdigest()


def pack_frame(msg_type, obj, binary=b"", version=PROTOCOL_VERSION):
    text = json.dumps(obj, separators=(",", ":")).encode("utf-8")
    return HEADER.pack(MAGIC, version, msg_type, len(text), len(binary)) + text


class Client(object):
    """One connection to `vsd serve`. Not thread-safe: use one Client per thread."""

    def __init__(self, address=None, token=None, timeout=120.0, client_name="vsd_client.py"):
        self.address = address or default_socket()
        self.timeout = timeout
        self._next_id = 1
        self.bytes_uploaded = 0
        if address and ":" in address and "/" not in address and not address.startswith("unix:"):
            host, port = address.rsplit(":", 1)
            self.sock = socket.create_connection((host, int(port)), timeout=timeout)
        else:
            path = self.address[5:] if self.address.startswith("unix:") else self.address
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.sock.settimeout(timeout)
            try:
                self.sock.connect(path)
            except OSError as e:
                self.sock.close()
                raise VsdError("connection", "cannot connect to %s: %s (is `vsd serve` running?)" % (path, e))
        hello = {"id": self._id(), "versions": [PROTOCOL_VERSION], "client": client_name}
        if token is not None:
            hello["token"] = token
        try:
            self.server = self._request(HELLO, hello)
        except Exception:
            self.sock.close()
            raise

    # -- plumbing ------------------------------------------------------------------------
    def _id(self):
        i = self._next_id
        self._next_id += 1
        return i

    def _send(self, msg_type, obj, binary=b""):
        try:
            self.sock.sendall(pack_frame(msg_type, obj, binary))
            if binary:
                self.sock.sendall(binary)
        except OSError as e:
            raise VsdError("connection", "sending to the daemon failed: %s" % e)

    def _recv_exact(self, n):
        buf = bytearray()
        while len(buf) < n:
            try:
                chunk = self.sock.recv(min(n - len(buf), 1 << 20))
            except socket.timeout:
                raise VsdError("connection", "the daemon did not answer in time")
            except OSError as e:
                raise VsdError("connection", "the connection broke: %s" % e)
            if not chunk:
                raise VsdError("connection", "the daemon closed the connection")
            buf += chunk
        return bytes(buf)

    def _recv(self):
        magic, version, msg_type, jlen, blen = HEADER.unpack(self._recv_exact(HEADER.size))
        if magic != MAGIC or version != PROTOCOL_VERSION or jlen > MAX_REPLY_JSON:
            raise VsdError("protocol", "the daemon sent an unreadable frame")
        msg = json.loads(self._recv_exact(jlen).decode("utf-8")) if jlen else {}
        binary = self._recv_exact(blen) if blen else b""
        return msg_type, msg, binary

    @staticmethod
    def _raise(msg):
        raise VsdError(msg.get("code", "unknown"), msg.get("message", ""), msg)

    def _request(self, msg_type, obj, binary=b""):
        self._send(msg_type, obj, binary)
        while True:
            t, msg, _ = self._recv()
            if t == ERROR and msg.get("id") in (obj["id"], None):
                self._raise(msg)
            if t == msg_type and msg.get("id") == obj["id"]:
                return msg

    # -- operations ----------------------------------------------------------------------
    def has(self, hashes):
        """The subset of `hashes` the daemon lacks (a list, in order)."""
        return self._request(HAS, {"id": self._id(), "hashes": list(hashes)})["missing"]

    def put(self, data, digest=None):
        """Send a blob; returns its hash. The daemon verifies it (hash_mismatch otherwise)."""
        digest = digest or hash_bytes(data)
        self._request(PUT, {"id": self._id(), "hash": digest}, data)
        self.bytes_uploaded += len(data)
        return digest

    def upload_file(self, path):
        """Hash a file and send it unless the daemon has it; returns "blob:<hash>"."""
        digest = hash_file(path)
        if self.has([digest]):
            with open(path, "rb") as f:
                data = f.read()
            if hash_bytes(data) != digest:
                raise VsdError("local", "%s changed while it was being sent" % path)
            self.put(data, digest)
        return "blob:" + digest

    def upload_files(self, paths, hashes=None, progress=None):
        """Send several files with one HAS, PUTting only what the daemon lacks. `hashes`
        (optional) maps path -> known SHA-256 hex (e.g. a caller's cache); progress(i, n)
        is called before each PUT. Returns {path: "blob:<hash>"}."""
        hashes = dict(hashes or {})
        for p in paths:
            if p not in hashes:
                hashes[p] = hash_file(p)
        wanted = list(dict.fromkeys(hashes[p] for p in paths))
        missing = set(self.has(wanted)) if wanted else set()
        todo = [p for p in dict.fromkeys(paths) if hashes[p] in missing]
        sent = set()
        for i, p in enumerate(todo):
            if hashes[p] in sent:
                continue
            if progress:
                progress(i, len(todo))
            with open(p, "rb") as f:
                data = f.read()
            if hash_bytes(data) != hashes[p]:
                raise VsdError("local", "%s changed while it was being sent" % p)
            self.put(data, hashes[p])
            sent.add(hashes[p])
        return {p: "blob:" + hashes[p] for p in paths}

    def render(self, scene, frame=None, overrides=None, preview=False, progress=None, cancel=None):
        """Render one frame. `scene` is a dict (or JSON text) of a scene file v1 whose files
        are "blob:<hash>" names. progress(stage, fraction) is called as PROGRESS arrives;
        cancel is a threading.Event or a callable returning True to send CANCEL.
        Returns a Result; raises VsdError (code "cancelled" after a cancel)."""
        rid = self.submit(scene, frame=frame, overrides=overrides, preview=preview)
        return self.wait_result(rid, progress=progress, cancel=cancel)

    def submit(self, scene, frame=None, overrides=None, preview=False):
        """Queue a render without waiting; returns its id for wait_result() / cancel()."""
        rid = self._id()
        msg = {"id": rid, "scene": scene}
        if frame is not None:
            msg["frame"] = int(frame)
        if overrides:
            msg["overrides"] = list(overrides)
        if preview:
            msg["preview"] = True
        self._send(RENDER, msg)
        return rid

    def wait_result(self, rid, progress=None, cancel=None):
        cancel_sent = False
        old = self.sock.gettimeout()
        deadline = time.monotonic() + self.timeout if self.timeout else None
        try:
            self.sock.settimeout(0.1 if cancel is not None else self.timeout)
            while True:
                if cancel is not None and not cancel_sent:
                    stop = cancel.is_set() if isinstance(cancel, threading.Event) else bool(cancel())
                    if stop:
                        self.cancel(rid, wait=False)
                        cancel_sent = True
                try:
                    head = self.sock.recv(HEADER.size, socket.MSG_PEEK)
                except socket.timeout:
                    if deadline and time.monotonic() > deadline and cancel is None:
                        raise VsdError("connection", "the daemon did not answer in time")
                    continue
                if not head:
                    raise VsdError("connection", "the daemon closed the connection")
                self.sock.settimeout(self.timeout)
                t, msg, binary = self._recv()
                self.sock.settimeout(0.1 if cancel is not None else self.timeout)
                mid = msg.get("id")
                if t == ERROR and mid in (rid, None):
                    self._raise(msg)
                if t == PROGRESS and mid == rid and progress:
                    progress(msg.get("stage", ""), float(msg.get("fraction", 0.0)))
                elif t == RESULT and mid == rid:
                    n_exr = int(msg.get("exr_bytes", 0))
                    n_png = int(msg.get("png_bytes", 0))
                    if n_exr + n_png != len(binary):
                        raise VsdError("protocol", "RESULT: part sizes do not add up")
                    return Result(msg, binary[:n_exr], binary[n_exr:] or None)
        finally:
            self.sock.settimeout(old)

    def cancel(self, rid, wait=True):
        """Ask the daemon to stop render `rid`; its render() then raises code "cancelled"."""
        cid = self._id()
        msg = {"id": cid, "job": rid}
        if not wait:
            self._send(CANCEL, msg)
            return None
        return self._request(CANCEL, msg).get("found", False)

    def stats(self):
        return self._request(STATS, {"id": self._id()})

    def close(self):
        try:
            self._send(BYE, {"id": self._id()})
        except VsdError:
            pass
        try:
            self.sock.close()
        except OSError:
            pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def render_sequence(client, scene, volume_files, env_file=None, frames=None, progress=None):
    """Stream a sequence: upload each frame's VDB files (only when missing), render the frame,
    yield (frame, Result). `volume_files` maps frame -> the local .vdb of the scene's one
    volume, or -> a list with one .vdb per entry of the scene's `volumes`."""
    scene = dict(scene)
    env_blob = client.upload_file(env_file) if env_file else None
    for frame in (frames or sorted(volume_files)):
        files = volume_files[frame]
        if isinstance(files, str):
            files = [files]
        if "volumes" in scene:
            if len(files) != len(scene["volumes"]):
                raise ValueError("frame %s: %d files for %d volumes" % (frame, len(files), len(scene["volumes"])))
            s = dict(scene, volumes=[dict(v, file=client.upload_file(f)) for v, f in zip(scene["volumes"], files)])
        else:
            s = dict(scene, volume=dict(scene.get("volume", {}), file=client.upload_file(files[0])))
        if env_blob:
            s["environment"] = dict(scene.get("environment", {}), file=env_blob)
        yield frame, client.render(s, frame=frame, progress=progress)
