#!/usr/bin/env python3
"""Package the Blender add-on: plugin_blender/vsd_blender/ (with its protocol client
vsd_client.py) -> a zip that Blender's Preferences > Add-ons > Install... takes. Copying the
folder into Blender's addons folder installs the same add-on.

    python3 plugin_blender/make_zip.py [OUT.zip]     (default: build/vsd_blender.zip)

CMake: `cmake --build build --target vsd_blender_zip` runs this (tests/blender_addon.cmake)."""
import os
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                          os.path.join(HERE, "..", "build", "vsd_blender.zip"))
    os.makedirs(os.path.dirname(out), exist_ok=True)
    pkg = os.path.join(HERE, "vsd_blender")
    tmp = out + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for name in sorted(os.listdir(pkg)):
            if name.endswith(".py"):
                z.write(os.path.join(pkg, name), "vsd_blender/" + name)
    os.replace(tmp, out)
    print(out)


if __name__ == "__main__":
    main()
