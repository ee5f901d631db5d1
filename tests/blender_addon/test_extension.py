# The add-on as a Blender 4.2+ extension (issue 28, finding 4):
# * `make_zip.py --extension` passes Blender's own validator (bl_pkg's command-line handler,
#   what `blender --command extension validate` runs), as do the manifest and the package in a
#   folder; Blender's `extension build` of that folder gives the same files as our zip; a
#   manifest that breaks Blender's rules is refused (so the validator really ran);
# * Install from Disk (extensions.package_install_files) into a temporary local repository
#   enables it as bl_ext.<repo>.vsd_blender, its preferences are found through __package__,
#   and F12 against a daemon renders smoke (Combined non-zero where the smoke is);
# * bpy.app.online_access off: a daemon on another host (TCP 192.0.2.1:7000) is an error
#   naming Allow Online Access, with no connection attempt and no auto-start; loopback TCP
#   (127.0.0.1, ::1, localhost) is still attempted;
# * the extension disables cleanly.
# Usage: blender -b --factory-startup --python-exit-code 1 --python test_extension.py -- VSD DATA TMP
# (Blender 4.2 or later; runs under the bpy wheels, tests/blender_extension.cmake.)
import os
import shutil
import socket
import subprocess
import sys
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402

REPO_MODULE = "vsd_test_repo"
EXT_NAME = "bl_ext.%s.vsd_blender" % REPO_MODULE
PLUGIN = os.path.join(common.REPO, "plugin_blender")


def python_exe():
    return sys.executable if os.path.basename(sys.executable).startswith("python") else "python3"


def blender_cli(args):
    """Blender's `blender --command extension ARGS` handler, run in this Blender; its exit code."""
    from bl_pkg import bl_extension_cli
    print("extension %s" % " ".join(args), flush=True)
    rc = bl_extension_cli.cli_extension_handler(list(args))
    sys.stdout.flush()
    return rc


def validate_and_build(tmp):
    """Our zip through Blender's validator and against Blender's own build of the same files."""
    zpath = os.path.join(tmp, "vsd_blender_extension.zip")
    subprocess.run([python_exe(), os.path.join(PLUGIN, "make_zip.py"), "--extension", zpath], check=True)
    check(blender_cli(["validate", zpath]) == 0, "Blender's validator accepts the extension zip")

    # the layout of `blender --command extension build`: a folder with the manifest and the package
    src = os.path.join(tmp, "ext_src")
    shutil.copytree(os.path.join(PLUGIN, "vsd_blender"), src, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(os.path.join(PLUGIN, "blender_manifest.toml"), src)
    check(blender_cli(["validate", src]) == 0, "Blender's validator accepts the manifest with the package folder")
    built = os.path.join(tmp, "blender_built.zip")
    check(blender_cli(["build", "--source-dir", src, "--output-filepath", built]) == 0 and os.path.isfile(built),
          "Blender's `extension build` builds the package folder")
    if os.path.isfile(built):
        with zipfile.ZipFile(zpath) as a, zipfile.ZipFile(built) as b:
            ours = {n: a.read(n) for n in a.namelist()}
            theirs = {n: b.read(n) for n in b.namelist() if not n.endswith("/")}
        check(ours == theirs, "make_zip.py --extension = Blender's build: the same files at the same paths "
              "(ours %s, Blender's %s)" % (sorted(ours), sorted(theirs)))

    # a manifest breaking Blender's rules (final period, over-long reason) is refused
    bad = os.path.join(tmp, "bad_src")
    shutil.copytree(src, bad)
    with open(os.path.join(bad, "blender_manifest.toml")) as f:
        text = f.read()
    text = text.replace('with the vsd daemon"', 'with the vsd daemon."')
    text = text.replace('over a Unix socket or TCP"', 'over a Unix socket or TCP, ' + "x" * 60 + '"')
    with open(os.path.join(bad, "blender_manifest.toml"), "w") as f:
        f.write(text)
    check(blender_cli(["validate", bad]) != 0, "Blender's validator refuses a tagline ending in '.' and a long reason")
    return zpath


def install_extension(tmp, zpath):
    """Install from Disk into a local repository in tmp (never the user's); the module name."""
    repo_dir = os.path.join(tmp, "extensions", REPO_MODULE)
    repo = bpy.context.preferences.extensions.repos.new(name="vsd test", module=REPO_MODULE,
                                                        custom_directory=repo_dir, source='USER')
    res = bpy.ops.extensions.package_install_files(filepath=zpath, repo=REPO_MODULE, enable_on_install=True)
    check(res == {"FINISHED"}, "extensions.package_install_files finished (%s)" % res)
    names = [k for k in bpy.context.preferences.addons.keys() if k.endswith("vsd_blender")]
    check(names == [EXT_NAME], "enabled as the extension module %s, no legacy add-on (%s)" % (EXT_NAME, names))
    mod = sys.modules.get(EXT_NAME)
    check(mod is not None and os.path.dirname(mod.__file__) == os.path.join(repo.directory, "vsd_blender"),
          "the module is loaded from the repository (%s)" % (mod and mod.__file__))
    check(os.path.isfile(os.path.join(repo.directory, "vsd_blender", "blender_manifest.toml")),
          "the installed extension carries its manifest")
    import addon_utils
    loaded_default, loaded_state = addon_utils.check(EXT_NAME)
    check(loaded_state, "addon_utils.check: %s is loaded" % EXT_NAME)
    common.ADDON = EXT_NAME
    return mod


def render_smoke(vsd, data, tmp, d):
    prefs = common.addon_prefs()
    check(hasattr(prefs, "vsd_path") and hasattr(prefs, "address"),
          "the preferences are registered under the extension's name (__package__)")
    prefs.vsd_path = vsd
    prefs.auto_start = False
    prefs.address = d.sock
    scene, ob = common.build_scene(data, width=64, height=36, frame_offset=20)  # file 21: a grown plume
    layer = scene.view_layers[0].name
    out = os.path.join(tmp, "extension_f12.exr")
    err = common.run_blender_render(out)
    check(err is None and os.path.isfile(out), "F12 through the extension (%s)" % err)
    if not os.path.isfile(out):
        return
    img, w, h = common.read_exr(out)
    comb = [img.get("%s.Combined.%s" % (layer, c)) for c in "RGBA"]
    check(all(c is not None for c in comb), "Combined RGBA in Blender's output (%s)" % sorted(img)[:8])
    if any(c is None for c in comb):
        return
    inside = [i for i, a in enumerate(comb[3]) if a > 0.05]
    check(len(inside) > 0.05 * w * h, "smoke covers part of the frame (%d of %d pixels)" % (len(inside), w * h))
    check(all(comb[0][i] + comb[1][i] + comb[2][i] > 0 for i in inside),
          "Combined RGB non-zero where the smoke is")


def online_access(vsd, tmp):
    """Remote TCP is refused while Blender's online access is off; loopback TCP is not."""
    conn = common.addon_module("connection")
    vsd_client = common.addon_module("vsd_client")
    online = getattr(bpy.app, "online_access", True)
    print("bpy.app.online_access = %s" % online, flush=True)
    check(online is False, "online access is off here (the bpy wheel's default, as --offline-mode)")
    calls, spawned = [], []
    real_connect, real_start = socket.create_connection, conn._start_daemon

    def fake_connect(addr, *a, **kw):
        calls.append(addr)
        raise ConnectionRefusedError("refused by the test")

    def fake_start(settings):
        spawned.append(settings.address)
        raise vsd_client.VsdError("connection", "auto-start stopped by the test")

    socket.create_connection, conn._start_daemon = fake_connect, fake_start
    prefs = common.addon_prefs()
    try:
        # F12 with a daemon on another host and auto-start on: refused before anything
        prefs.address, prefs.token, prefs.auto_start = "192.0.2.1:7000", "secret", True
        err = common.run_blender_render()
        print("remote TCP ->", err, flush=True)
        if not online:
            check(err is not None and "Allow Online Access" in err and "192.0.2.1:7000" in err,
                  "remote TCP with online access off: an error naming Allow Online Access (%s)" % err)
            check(calls == [] and spawned == [], "no connection attempt and no auto-start (%s, %s)" % (calls, spawned))
            # the panel's Check Daemon says the same
            st = conn.refresh_status(conn.Settings(address="remote.example:7000", token="x", auto_start=True))
            check(not st["ok"] and "Allow Online Access" in st["text"] and calls == [],
                  "Check Daemon: the same refusal, no connection (%s)" % st["text"])
        else:
            check(calls == [("192.0.2.1", 7000)], "online access on: remote TCP is attempted (%s)" % calls)

        # loopback TCP is local, not online: attempted (and refused by the stub)
        for address, host in (("127.0.0.1:7000", "127.0.0.1"), ("127.1.2.3:7000", "127.1.2.3"),
                              ("localhost:7000", "localhost"), ("::1:7000", "::1")):
            del calls[:]
            try:
                conn.client(conn.Settings(address=address, token="x", auto_start=False), fresh=True)
                res = "connected?"
            except vsd_client.VsdError as e:
                res = e.message
            check(calls == [(host, 7000)] and "Allow Online Access" not in res,
                  "loopback %s is attempted (%s: %s)" % (address, calls, res))
    finally:
        socket.create_connection, conn._start_daemon = real_connect, real_start
        prefs.auto_start, prefs.token = False, ""


def main():
    vsd, data, tmp, _ = common.args()
    common.fresh_tmp(tmp)
    if bpy.app.version < (4, 2, 0):
        print("test_extension: Blender %s has no extensions (4.2+): nothing to test" % bpy.app.version_string)
        common.finish("test_extension")
        return
    zpath = validate_and_build(tmp)
    install_extension(tmp, zpath)
    d = common.Daemon(vsd, tmp)
    try:
        render_smoke(vsd, data, tmp, d)
        online_access(vsd, tmp)
    finally:
        rc = d.stop()
    check(rc == 0, "daemon exited cleanly (%s)" % rc)
    res = bpy.ops.preferences.addon_disable(module=EXT_NAME)
    check(res == {"FINISHED"} and EXT_NAME not in bpy.context.preferences.addons.keys(),
          "the extension disables (%s)" % res)
    common.finish("test_extension")


main()
