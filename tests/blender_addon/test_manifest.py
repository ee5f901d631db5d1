# The extension manifest (plugin_blender/blender_manifest.toml) and the zips of
# plugin_blender/make_zip.py, in plain Python (no Blender; Blender's own validator runs in
# blender<tag>_addon_extension):
# * the fields Blender's manifest schema 1.0.0 requires are there, with its rules for the
#   short texts (tagline, permission reasons: at most 64 characters, no final punctuation);
# * version equals bl_info["version"] of vsd_blender/__init__.py and id the package's folder
#   name, so the two cannot drift apart;
# * `make_zip.py --extension`: the manifest and every .py of the package at the zip's root;
#   `make_zip.py` (legacy, Blender 3.4): the same files under vsd_blender/, no manifest.
# Usage: python3 tests/blender_addon/test_manifest.py   (exit 0 = passed, 77 = no tomllib)
import ast
import os
import subprocess
import sys
import tempfile
import zipfile

try:
    import tomllib
except ImportError:  # Python < 3.11
    print("SKIP: tomllib needs Python 3.11 (this is %s)" % sys.version.split()[0])
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
PLUGIN = os.path.join(os.path.dirname(os.path.dirname(HERE)), "plugin_blender")
PKG = os.path.join(PLUGIN, "vsd_blender")
failures = []


def check(cond, what):
    print(("ok:   " if cond else "FAIL: ") + what)
    if not cond:
        failures.append(what)


def bl_info():
    """bl_info of the package's __init__.py, read without importing it (it imports bpy)."""
    with open(os.path.join(PKG, "__init__.py")) as f:
        tree = ast.parse(f.read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "bl_info" for t in node.targets):
            return ast.literal_eval(node.value)
    raise AssertionError("no bl_info in vsd_blender/__init__.py")


def terse_ok(text):
    """Blender's rule for tagline and permission reasons (blender_ext.py,
    pkg_manifest_validate_terse_description_or_error)."""
    return (isinstance(text, str) and 0 < len(text) <= 64 and text == text.strip()
            and (text[-1].isalnum() or text[-1] in ")]}"))


with open(os.path.join(PLUGIN, "blender_manifest.toml"), "rb") as f:
    m = tomllib.load(f)
info = bl_info()

for key in ("schema_version", "id", "version", "name", "tagline", "maintainer", "type", "license",
            "blender_version_min"):
    check(key in m, "manifest has %s (%r)" % (key, m.get(key)))
check(m.get("schema_version") == "1.0.0", "schema_version 1.0.0")
check(m.get("id") == os.path.basename(PKG), "id %r = the package folder's name (module bl_ext.<repo>.%s)"
      % (m.get("id"), os.path.basename(PKG)))
check(m.get("version") == ".".join(str(v) for v in info["version"]),
      "manifest version %r = bl_info version %r" % (m.get("version"), info["version"]))
check(m.get("name") == info["name"], "name %r = bl_info name" % m.get("name"))
check(m.get("type") == "add-on", "type add-on")
check(terse_ok(m.get("tagline")), "tagline: at most 64 characters, no final punctuation (%r)" % m.get("tagline"))
bv = m.get("blender_version_min", "")
check(bv.count(".") == 2 and all(p.isdigit() for p in bv.split(".")) and
      tuple(int(p) for p in bv.split(".")) >= (4, 2, 0), "blender_version_min %r: X.Y.Z, 4.2.0 or later" % bv)
lic = m.get("license")
check(isinstance(lic, list) and lic and all(isinstance(x, str) and x.startswith("SPDX:") for x in lic),
      "license: a list of SPDX: identifiers (%r)" % lic)
check(m.get("tags", []) and info["category"] in m.get("tags", []),
      "tags include bl_info's category %r (%r)" % (info["category"], m.get("tags")))
perms = m.get("permissions", {})
check(isinstance(perms, dict) and set(perms) == {"network", "files"},
      "permissions: network and files (%r)" % sorted(perms))
for key, reason in perms.items():
    check(terse_ok(reason), "permission %s: a reason of at most 64 characters, no final punctuation (%r)"
          % (key, reason))
check("build" not in m, "no [build] table (make_zip.py builds the zip)")

# ---- the zips ------------------------------------------------------------------------------
py_files = sorted(n for n in os.listdir(PKG) if n.endswith(".py"))
with tempfile.TemporaryDirectory() as d:
    ext, leg = os.path.join(d, "ext.zip"), os.path.join(d, "legacy.zip")
    subprocess.run([sys.executable, os.path.join(PLUGIN, "make_zip.py"), "--extension", ext], check=True)
    subprocess.run([sys.executable, os.path.join(PLUGIN, "make_zip.py"), leg], check=True)
    with zipfile.ZipFile(ext) as z:
        names = z.namelist()
        check(sorted(names) == sorted(["blender_manifest.toml"] + py_files),
              "extension zip: the manifest and the package's .py files at its root (%s)" % names)
        check(z.read("blender_manifest.toml") == open(os.path.join(PLUGIN, "blender_manifest.toml"), "rb").read(),
              "extension zip: the manifest unchanged")
        check(all(z.read(n) == open(os.path.join(PKG, n), "rb").read() for n in py_files),
              "extension zip: the .py files unchanged")
    with zipfile.ZipFile(leg) as z:
        names = z.namelist()
        check(sorted(names) == ["vsd_blender/" + n for n in py_files],
              "legacy zip: the .py files under vsd_blender/, no manifest (%s)" % names)

if failures:
    print("test_manifest: %d check(s) failed: %s" % (len(failures), "; ".join(failures)))
    sys.exit(1)
print("test_manifest: all checks passed")
