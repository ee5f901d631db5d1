#!/usr/bin/env python3
"""plugin_blender/vsd_blender/vsd_client.py against a real `vsd serve` started here on a temp socket.

Usage: test_python_client.py VSD SHARED_DATA TMP_DIR
Checks HELLO, SHA-256 blob upload (sent once), render with progress (EXR bytes, preview
PNG), camera change reusing the preparation, errors with stable codes (missing blob,
hash mismatch, invalid scene), CANCEL, STATS, and that SIGTERM removes the socket."""
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "plugin_blender", "vsd_blender"))
import vsd_client  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what, file=sys.stderr)


def main():
    vsd, data, tmp = sys.argv[1], sys.argv[2], sys.argv[3]
    vol = [os.path.join(data, "smoke64", "fluid_data_%04d.vdb" % i) for i in (1, 2, 3)]
    env = os.path.join(data, "env", "sunset.exr")
    if not os.path.exists(vol[0]):
        print("no shared data: skipped")
        return 77
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    sock = os.path.join(tmp, "py.sock")
    ready = os.path.join(tmp, "ready.json")
    log = open(os.path.join(tmp, "daemon.log"), "w")
    proc = subprocess.Popen([vsd, "serve", "--socket", sock, "--ready-file", ready, "--cache-dir", tmp,
                             "--log-level", "debug"], stderr=log)
    try:
        for _ in range(200):
            if os.path.exists(ready):
                break
            time.sleep(0.05)
        check(os.path.exists(ready), "daemon started")
        check(json.load(open(ready))["socket"] == sock, "ready file names the socket")
        check(oct(os.stat(sock).st_mode & 0o777) == "0o600", "socket mode 0600")

        c = vsd_client.Client(sock)
        check(c.server["version"] == 1, "HELLO version")
        check("raymarch" in c.server["methods"], "HELLO methods")
        check("sha256" in c.server["hashes"], "daemon takes sha256 names")
        for k in ("max_message_bytes", "max_pixels", "max_voxels", "max_job_seconds", "queue_length"):
            check(k in c.server["limits"], "HELLO limit " + k)

        scene = {"version": 1, "volume": {"file": None, "grid": "density"}, "medium": {"density": 8},
                 "environment": {"file": None},
                 "camera": {"position": [1, -3.9745, 1.8771], "look_at": [1, 1, 1], "up": [0, 0, 1], "fov": 0.7},
                 "film": {"width": 32, "height": 18},
                 "render": {"method": "raymarch", "options": {"lights": 8}}}

        # streaming three frames twice: the second time nothing is uploaded
        files = {i + 1: vol[i] for i in range(3)}
        stages = []
        results = list(vsd_client.render_sequence(c, scene, files, env_file=env,
                                                  progress=lambda s, f: stages.append((s, f))))
        first = c.bytes_uploaded
        check(first == sum(os.path.getsize(p) for p in vol) + os.path.getsize(env), "first pass uploads everything")
        check(len(results) == 3 and all(r.exr[:4] == b"\x76\x2f\x31\x01" for _, r in results), "EXR bytes returned")
        check(any(s == "ray marching" for s, _ in stages), "progress stages arrive")
        results = list(vsd_client.render_sequence(c, scene, files, env_file=env))
        check(c.bytes_uploaded == first, "second pass uploads no bytes")
        check(all(r.cache.get("preparation") for _, r in results), "second pass reuses the preparation")

        # a scene with two volumes (reference renders several): each frame's files go to their
        # own volume
        two = {k: v for k, v in scene.items() if k not in ("volume", "medium")}
        two["volumes"] = [{"grid": "density", "medium": {"density": 8}},
                          {"grid": "density", "matrix": [1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],
                           "medium": {"density": 4, "albedo": [0.9, 0.5, 0.2]}}]
        two["render"] = {"method": "reference", "samples": 2}
        pairs = {1: [vol[0], vol[1]], 2: [vol[0], vol[2]]}
        before = c.bytes_uploaded
        results = list(vsd_client.render_sequence(c, two, pairs, env_file=env))
        check(len(results) == 2 and all(len(r.cache.get("volumes", [])) == 2 for _, r in results),
              "two volumes: two frames rendered, a cache entry per volume")
        check(c.bytes_uploaded == before, "two volumes: files the daemon has are not uploaded again")
        check(results[0][1].exr != results[1][1].exr, "two volumes: frame 2's second volume changes the image")

        # camera change: the prepared renderer is reused
        s = dict(scene, volume=dict(scene["volume"], file=c.upload_file(vol[0])),
                 environment={"file": c.upload_file(env)})
        s["camera"] = dict(scene["camera"], position=[1.5, -3.9, 1.9])
        r = c.render(s, frame=1, preview=True)
        check(r.cache.get("renderer") and r.cache.get("preparation"), "camera change reuses the preparation")
        check(r.png is not None and r.png[:8] == b"\x89PNG\r\n\x1a\n", "preview PNG returned")
        check(r.info["width"] == 32 and r.info["height"] == 18, "RESULT size")

        # errors carry stable codes and leave the connection usable
        def expect(code, fn, what):
            try:
                fn()
                check(False, what + ": no error")
            except vsd_client.VsdError as e:
                check(e.code == code, "%s: code %s (expected %s): %s" % (what, e.code, code, e.message))

        missing = "ab" * 32
        expect("missing_blob", lambda: c.render(dict(s, volume={"file": "blob:" + missing})), "missing blob")
        expect("hash_mismatch", lambda: c.put(b"hello", "00" * 32), "hash mismatch")
        expect("invalid_scene", lambda: c.render(dict(s, camera={"fov": "wide"})), "invalid scene")
        expect("path_denied", lambda: c.render(dict(s, volume={"file": vol[0]})), "server path without --allow-path")
        check(c.has([missing]) == [missing], "HAS lists a missing hash")

        # CANCEL a long render
        slow = dict(s, film={"width": 64, "height": 64}, render={"method": "reference", "samples": 1000000})
        ev = threading.Event()
        threading.Timer(0.4, ev.set).start()
        t0 = time.monotonic()
        expect("cancelled", lambda: c.render(slow, cancel=ev), "cancel")
        check(time.monotonic() - t0 < 5, "cancel is quick")

        st = c.stats()
        check(st["jobs"]["done"] >= 7 and st["cache"]["used_bytes"] <= st["cache"]["budget_bytes"], "STATS")
        check(st["uptime_seconds"] > 0 and st["server_version"], "STATS version and uptime")
        c.close()

        # a fresh client still works after all of that
        with vsd_client.Client(sock) as c2:
            r = c2.render(s, frame=1)
            check(len(r.exr) > 100, "render after errors")
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            rc = proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            rc = -1
        log.close()
    check(rc == 0, "daemon exits 0 on SIGTERM (got %s)" % rc)
    check(not os.path.exists(sock), "SIGTERM removes the socket")
    if failures:
        print("test_python_client: %d check(s) failed" % len(failures), file=sys.stderr)
        return 1
    print("test_python_client: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
