#!/usr/bin/env python3
"""Runs a Blender test script under a `bpy` wheel (Blender as a Python module) the way

    blender --background --factory-startup --python-exit-code 1 --python SCRIPT -- ARGS

runs it in a Blender binary, so the add-on tests run unchanged on the Blenders that PyPI
ships (4.2, 4.5, 5.0; scripts/install-blender-wheels.sh installs them):

    <cache>/bpy-4.5.15/bin/python tests/blender_addon/blender_wheel.py \
        [--background] [--factory-startup] [--python-exit-code N] --python SCRIPT [-- ARGS]

What differs from the binary, and how this runner bridges it:
* the module is always "background": there is no window, so `bpy.app.timers` never fire
  (a test that needs a timer's work, such as the viewport's result poll, calls it by hand);
* Blender reads the user's configuration on import: BLENDER_USER_* point at a temporary
  folder first, and --factory-startup reloads the factory settings, so nothing of the
  user's is read or written;
* sys.argv is [python, <the arguments above>], so a script's `sys.argv.index("--")` works;
* an uncaught exception prints its traceback and exits with --python-exit-code (as the
  binary does); a script that finishes exits 0 unless it called sys.exit/os._exit itself.
"""
import os
import runpy
import shutil
import sys
import tempfile
import traceback


def parse(argv):
    script, exit_code, factory, rest = None, 0, False, []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--":
            rest = argv[i:]
            break
        if a in ("-b", "--background"):
            pass
        elif a == "--factory-startup":
            factory = True
        elif a == "--python-exit-code":
            i += 1
            exit_code = int(argv[i])
        elif a in ("-P", "--python"):
            i += 1
            script = argv[i]
        else:
            sys.exit("blender_wheel.py: unsupported argument %r (see the docstring)" % a)
        i += 1
    if script is None:
        sys.exit("blender_wheel.py: --python SCRIPT is required")
    return script, exit_code, factory, rest


def main():
    script, exit_code, factory, rest = parse(sys.argv[1:])
    home = tempfile.mkdtemp(prefix="vsd_bpy_home_")
    for var in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_DATAFILES",
                "BLENDER_USER_RESOURCES", "BLENDER_USER_EXTENSIONS"):
        os.environ[var] = os.path.join(home, var.rsplit("_", 1)[-1].lower())
    try:
        import bpy
        if factory:
            bpy.ops.wm.read_factory_settings(use_empty=False)
        print("blender_wheel: Blender %s (bpy module, Python %s)" % (bpy.app.version_string, sys.version.split()[0]),
              flush=True)
        sys.argv = [sys.executable, "--background", "--python", script] + rest
        try:
            runpy.run_path(script, run_name="__main__")
        except SystemExit:
            raise
        except BaseException:
            traceback.print_exc()
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(exit_code)
    finally:
        shutil.rmtree(home, ignore_errors=True)
    sys.stdout.flush()
    # os._exit: the module's atexit handlers can crash on shutdown after a render in some
    # versions; the script's result is decided by now.
    os._exit(0)


if __name__ == "__main__":
    main()
