#!/usr/bin/env python3
"""Package the Blender add-on: plugin_blender/vsd_blender/ (with its protocol client
vsd_client.py) -> a zip that Blender installs.

    python3 plugin_blender/make_zip.py [OUT.zip]                (default: build/vsd_blender.zip)
    python3 plugin_blender/make_zip.py --extension [OUT.zip]    (default: build/vsd_blender_extension.zip)

* The legacy zip (Blender 3.4 and later: Preferences > Add-ons > Install...) holds the
  folder vsd_blender/; copying the folder into Blender's addons folder installs the same add-on.
* --extension: the extension zip (Blender 4.2 and later: Preferences > Get Extensions >
  Install from Disk..., or `blender --command extension install-file -r user_default -e ZIP`):
  plugin_blender/blender_manifest.toml and the package's .py files at the zip's root, the
  layout `blender --command extension build` writes from a folder holding both. The module
  is then bl_ext.<repository>.vsd_blender.

CMake: `cmake --build build --target vsd_blender_zip` (tests/blender_addon.cmake) and
`--target vsd_blender_extension_zip` (tests/blender_extension.cmake) run this."""
import os
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
MANIFEST = os.path.join(HERE, "blender_manifest.toml")


def main():
    argv = sys.argv[1:]
    extension = "--extension" in argv
    argv = [a for a in argv if a != "--extension"]
    if len(argv) > 1 or any(a.startswith("-") for a in argv):
        sys.exit(__doc__)
    default = "vsd_blender_extension.zip" if extension else "vsd_blender.zip"
    out = os.path.abspath(argv[0] if argv else os.path.join(HERE, "..", "build", default))
    os.makedirs(os.path.dirname(out), exist_ok=True)
    pkg = os.path.join(HERE, "vsd_blender")
    # extension: files at the root, the manifest first (as Blender's build writes it);
    # legacy: everything under the package's folder name
    prefix = "" if extension else "vsd_blender/"
    tmp = out + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        if extension:
            z.write(MANIFEST, "blender_manifest.toml")
        for name in sorted(os.listdir(pkg)):
            if name.endswith(".py"):
                z.write(os.path.join(pkg, name), prefix + name)
    os.replace(tmp, out)
    print(out)


if __name__ == "__main__":
    main()
