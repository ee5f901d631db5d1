#!/usr/bin/env bash
# Installs PyPI's `bpy` wheels (Blender as a Python module) into one virtual environment
# per Blender version, for the add-on tests (tests/blender/run_wheel.py). Test tooling only:
# users run vsd with what scripts/install-deps.sh installs from Debian.
#
#   scripts/install-blender-wheels.sh [--print-dir] [VERSION ...]
#
# Versions default to the ones the add-on is tested on (4.2 LTS, 4.5 LTS, 5.0). The cache
# folder is $VSD_BLENDER_WHEELS, else ~/.cache/vsd/blender-wheels; each version lives in
# <cache>/bpy-<version>/ and is reinstalled only when its marker file is missing. A wheel
# needs CPython 3.11 (the wheels for 4.1-5.0 are cp311 only; 5.1+ need 3.13).
set -euo pipefail

versions_default=(4.2.23 4.5.15 5.0.1)
cache=${VSD_BLENDER_WHEELS:-$HOME/.cache/vsd/blender-wheels}

if [[ ${1:-} == --print-dir ]]; then echo "$cache"; exit 0; fi
versions=("$@")
[[ ${#versions[@]} -gt 0 ]] || versions=("${versions_default[@]}")

# A CPython 3.11 with venv + ensurepip: the PATH's python3, else Debian's with python3-venv.
python=""
for candidate in python3.11 python3 /usr/bin/python3; do
  if command -v "$candidate" >/dev/null 2>&1 &&
     "$candidate" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
    python=$(command -v "$candidate"); break
  fi
done
if [[ -z $python ]]; then
  sudo_cmd=""; [[ $(id -u) -eq 0 ]] || sudo_cmd=sudo
  $sudo_cmd apt-get install -y -q python3-venv >/dev/null
  python=/usr/bin/python3
  "$python" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info[:2] != (3, 11))' ||
    { echo "install-blender-wheels: no CPython 3.11 with venv here; the bpy wheels need one" >&2; exit 1; }
fi

# The system libraries the wheels link (readelf -d bpy/__init__.so: X11, XKB, Vulkan loader,
# TBB); Debian's blender package pulls them in, `install-deps.sh --no-blender` does not.
runtime_libs=(libx11-6 libxfixes3 libxi6 libxkbcommon0 libxrender1 libvulkan1 libtbb12)
missing=()
for pkg in "${runtime_libs[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "ok installed" || missing+=("$pkg")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  sudo_cmd=""; [[ $(id -u) -eq 0 ]] || sudo_cmd=sudo
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
fi

mkdir -p "$cache"
for version in "${versions[@]}"; do
  dir=$cache/bpy-$version
  if [[ -f $dir/.installed ]]; then echo "bpy $version: $dir (cached)"; continue; fi
  rm -rf "$dir"
  "$python" -m venv "$dir"
  start=$SECONDS
  # --no-cache-dir: the wheels are 300+ MB each, pip's own cache would hold a second copy.
  "$dir/bin/python" -m pip install -q --no-cache-dir --disable-pip-version-check "bpy==$version"
  "$dir/bin/python" -c 'import bpy, sys; print("bpy", bpy.app.version_string, "python", sys.version.split()[0])'
  touch "$dir/.installed"
  echo "bpy $version: $dir ($((SECONDS - start)) s)"
done
