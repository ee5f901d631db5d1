#!/usr/bin/env bash
# Installs every build, test and tool dependency of vsd from Debian's archive (apt-get only).
# Usage: scripts/install-deps.sh [--no-blender]
#   --no-blender   skip Blender (the Cycles cross-check and add-on tests then skip themselves)
set -euo pipefail

with_blender=1
for arg in "$@"; do
  case "$arg" in
    --no-blender) with_blender=0 ;;
    *) echo "install-deps.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

sudo_cmd=""
if [ "$(id -u)" -ne 0 ]; then sudo_cmd="sudo"; fi

packages=(
  build-essential cmake pkg-config
  clang libclang-rt-14-dev
  libopenvdb-dev libboost-dev libtbb-dev libblosc-dev zlib1g-dev
  libopenexr-dev libimath-dev
  libopencolorio-dev
  libpng-dev
  libcjson-dev
  libxxhash-dev
  libchealpix-dev
  libnlopt-dev libopenblas-dev liblapacke-dev
  nettle-dev
  openimageio-tools
  xvfb xauth
  povray
  slurm-wlm munge
)
if [ "$with_blender" -eq 1 ]; then packages+=(blender); fi

export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -q
$sudo_cmd apt-get install -y -q --no-install-recommends "${packages[@]}"
