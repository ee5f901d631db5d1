# The add-on's link to `vsd serve`: one protocol client (vsd_client.py) per thread, the
# daemon address from the preferences, auto-start of a private daemon when none answers
# (stopped when Blender exits), and a cache of file hashes so an animation hashes each
# .vdb once and uploads only what the daemon lacks (HAS, then PUT).
import atexit
import ipaddress
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time

from . import method_catalog, vsd_client

_lock = threading.Lock()
_clients = {}          # thread id -> (key, Client)
_daemon = {"proc": None, "dir": None, "address": None, "log": None}
_hashes = {}           # (path, size, mtime_ns) -> sha256 hex
status = {"text": "not checked", "ok": False}   # shown in the render panel


class Settings(object):
    """Connection settings, from the add-on preferences or given directly (tests)."""

    def __init__(self, vsd_path="", address="", token="", auto_start=True, timeout=600.0):
        self.vsd_path = vsd_path
        self.address = address
        self.token = token
        self.auto_start = auto_start
        self.timeout = timeout

    @classmethod
    def from_prefs(cls, prefs):
        if prefs is None:
            return cls()
        return cls(prefs.vsd_path, prefs.address, prefs.token, prefs.auto_start)


def _is_tcp(address):
    return bool(address) and ":" in address and "/" not in address and not address.startswith("unix:")


def _is_loopback(host):
    """127.0.0.0/8, ::1 (also as [::1]) or localhost; a name is not resolved (that would be a
    lookup on the network itself)."""
    host = host.strip().strip("[]").lower()
    if host == "localhost" or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_online_access(address):
    """Blender 4.2+ has Allow Online Access (bpy.app.online_access), and its extension rules
    say an add-on must not go online while it is off. The default Unix socket and TCP to this
    machine are local, not online; TCP to another host is, so it is refused before any
    connection (or auto-start) is tried. Blender before 4.2 has no such setting: allowed."""
    if not _is_tcp(address) or _is_loopback(address.rsplit(":", 1)[0]):
        return
    try:
        import bpy
        allowed = getattr(bpy.app, "online_access", True)
    except ImportError:   # outside Blender (tests of this module)
        allowed = True
    if not allowed:
        raise vsd_client.VsdError("connection", "the daemon address %s is on another host, and "
                                  "Blender's online access is off: turn on Preferences > System > "
                                  "Network > Allow Online Access, or use a local daemon" % address)


def resolve_address(address):
    return address.strip() if address and address.strip() else vsd_client.default_socket()


def find_vsd(path):
    """The vsd executable: the preference, else `vsd` on PATH."""
    if path:
        p = os.path.abspath(os.path.expanduser(bpy_abspath(path)))
        if os.path.isfile(p) and os.access(p, os.X_OK):
            return p
        raise vsd_client.VsdError("connection", "the vsd binary set in the add-on preferences "
                                  "does not exist or is not executable: %s" % p)
    p = shutil.which("vsd")
    if p:
        return p
    raise vsd_client.VsdError("connection", "cannot find the `vsd` binary: set its path in "
                              "Preferences > Add-ons > vsd")


def bpy_abspath(path):
    try:
        import bpy
        return bpy.path.abspath(path)
    except Exception:
        return path


def _start_daemon(settings):
    """Spawn `vsd serve` on the configured address and wait for its ready file."""
    exe = find_vsd(settings.vsd_path)
    address = resolve_address(settings.address)
    stop_daemon()
    d = tempfile.mkdtemp(prefix="vsd_blender_")
    ready = os.path.join(d, "ready.json")
    cmd = [exe, "serve", "--ready-file", ready, "--cache-dir", d]
    if _is_tcp(address):
        if not settings.token:
            raise vsd_client.VsdError("connection", "auto-start on TCP %s needs a token in the "
                                      "add-on preferences" % address)
        tf = os.path.join(d, "token")
        fd = os.open(tf, os.O_WRONLY | os.O_CREAT, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(settings.token)
        cmd += ["--socket", os.path.join(d, "vsd.sock"), "--tcp", address, "--token-file", tf]
    else:
        path = address[5:] if address.startswith("unix:") else address
        cmd += ["--socket", path]
    log = open(os.path.join(d, "daemon.log"), "w")
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                            start_new_session=True)
    _daemon.update(proc=proc, dir=d, address=address, log=log)
    deadline = time.monotonic() + 15.0
    while time.monotonic() < deadline:
        if os.path.exists(ready):
            return
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    log.flush()
    try:
        tail = open(os.path.join(d, "daemon.log")).read().strip().splitlines()[-3:]
    except OSError:
        tail = []
    stop_daemon()
    raise vsd_client.VsdError("connection", "auto-start: `vsd serve` did not start%s"
                              % (": " + " / ".join(tail) if tail else ""))


def stop_daemon():
    """Stop the daemon this add-on started (SIGTERM, then SIGKILL), if any."""
    proc = _daemon.get("proc")
    if proc is not None and proc.poll() is None:
        try:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=10)
        except Exception:
            try:
                proc.kill()
                proc.wait(timeout=5)
            except Exception:
                pass
    if _daemon.get("log"):
        try:
            _daemon["log"].close()
        except Exception:
            pass
    if _daemon.get("dir"):
        shutil.rmtree(_daemon["dir"], ignore_errors=True)
    _daemon.update(proc=None, dir=None, address=None, log=None)


def daemon_started_here():
    proc = _daemon.get("proc")
    return proc is not None and proc.poll() is None


atexit.register(stop_daemon)


def _connect(settings, address):
    return vsd_client.Client(address, token=settings.token or None, timeout=settings.timeout,
                             client_name="vsd_blender")


def client(settings, fresh=False):
    """A connected Client for this thread, reused across frames. Starts a daemon when none
    answers and auto-start is on; raises VsdError otherwise."""
    address = resolve_address(settings.address)
    check_online_access(address)   # before any connection or auto-start
    key = (address, settings.token)
    tid = threading.get_ident()
    with _lock:
        entry = _clients.get(tid)
    if entry and entry[0] == key and not fresh:
        return entry[1]
    if entry:
        drop(tid)
    try:
        c = _connect(settings, address)
    except vsd_client.VsdError as e:
        if e.code != "connection" or not settings.auto_start:
            if e.code == "connection":
                raise vsd_client.VsdError("connection", "no vsd daemon answers at %s (start "
                                          "`vsd serve`, or turn on auto-start in the add-on "
                                          "preferences)" % address)
            raise
        _start_daemon(settings)
        c = _connect(settings, address)
    except OSError as e:  # TCP connect refused
        if not settings.auto_start:
            raise vsd_client.VsdError("connection", "no vsd daemon answers at %s: %s" % (address, e))
        _start_daemon(settings)
        c = _connect(settings, address)
    with _lock:
        _clients[tid] = (key, c)
    # this daemon's method catalog (applied on the main thread by a timer)
    method_catalog.from_hello(c.server, main_thread=False)
    return c


def drop(tid=None):
    """Forget (and close) this thread's client, e.g. after a broken connection."""
    tid = tid if tid is not None else threading.get_ident()
    with _lock:
        entry = _clients.pop(tid, None)
    if entry:
        try:
            entry[1].sock.close()
        except Exception:
            pass


def close_all():
    with _lock:
        entries = list(_clients.values())
        _clients.clear()
    for _, c in entries:
        try:
            c.close()
        except Exception:
            pass


def file_hash(path):
    st = os.stat(path)
    key = (path, st.st_size, st.st_mtime_ns)
    h = _hashes.get(key)
    if h is None:
        h = vsd_client.hash_file(path)
        _hashes[key] = h
    return h


def upload(c, paths, progress=None):
    """{path: "blob:<hash>"}, sending only the files the daemon lacks."""
    hashes = {p: file_hash(p) for p in paths}
    return c.upload_files(paths, hashes=hashes, progress=progress)


def with_retry(settings, fn):
    """Run fn(client); if the kept connection turned out to be broken (daemon restarted),
    reconnect once and run it again."""
    c = client(settings)
    try:
        return fn(c)
    except vsd_client.VsdError as e:
        if e.code not in ("connection", "protocol", "shutdown"):
            raise
        drop()
        return fn(client(settings, fresh=True))


def refresh_status(settings):
    """Connect, ask STATS, and describe the daemon for the panel."""
    try:
        def go(c):
            return c.server, c.stats()
        server, st = with_retry(settings, go)
        cache = st.get("cache", {})
        used = cache.get("used_bytes", 0) / 1048576.0
        budget = cache.get("budget_bytes", 0) / 1048576.0
        status["text"] = "connected: vsd %s, cache %.0f / %.0f MB, jobs done %d%s" % (
            server.get("server_version", "?"), used, budget, st.get("jobs", {}).get("done", 0),
            " (started by Blender)" if daemon_started_here() else "")
        status["ok"] = True
        status["methods"] = server.get("methods", [])
        method_catalog.from_hello(server, main_thread=True)
        status["devices"] = server.get("devices", [])
    except vsd_client.VsdError as e:
        status["text"] = "not connected: %s" % e.message
        status["ok"] = False
    return status


def stats_text(st):
    return json.dumps(st)
