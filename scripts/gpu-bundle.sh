#!/usr/bin/env bash
# Builds the CUDA backend for the GPU machine (sm_90, Release) into build-gpu/ and packs
# build-gpu/bundle/: the vsd (with vsd-core), test_cuda and bench_device executables, every shared library
# they load except glibc's own, and exactly the data files the GPU test and benchmark read.
# The GPU machine has CUDA and a driver but none of Debian's libraries, and takes at most
# 64 MiB of files, so the bundle is one xz tarball that must stay under 48 MiB.
#
# Usage: scripts/gpu-bundle.sh [--no-build] [--no-check]
#   --no-build  pack what build-gpu/ already holds
#   --no-check  skip the self-check (unpacking into an empty folder and rendering there
#               under `env -i` with LD_LIBRARY_PATH pointing only at the bundle)
# Then, on the GPU machine: scripts/gpu-run.sh (see docs/gpu.md).
set -euo pipefail
cd "$(dirname "$0")/.."

build=1 check=1
for arg in "$@"; do
  case "$arg" in
    --no-build) build=0 ;;
    --no-check) check=0 ;;
    *) echo "gpu-bundle.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

data_src=${VSD_SHARED_DATA:-$PWD/../shared/data}
max_mib=48
bundle=build-gpu/bundle
stage=build-gpu/bundle-stage
programs=(vsd vsd-core tests/test_cuda bench_device)
# What test_cuda and bench_device read (tests/test_cuda.c, bench/device/bench_device.c's
# default scenes at their first frames), plus what those scene files name.
data_files=(
  scenes/smoke64_sunset.json scenes/smoke128_forest.json scenes/fire96_studio.json
  scenes/cloud128_interior.json
  smoke64/fluid_data_0001.vdb smoke64/fluid_data_0024.vdb
  smoke128/fluid_data_0045.vdb fire96/fluid_data_0048.vdb cloud/cloud128.vdb
  env/sunset.exr env/forest.exr env/studio.exr env/interior.hdr
)

if [ "$build" -eq 1 ]; then
  command -v nvcc >/dev/null || [ -x /usr/local/cuda/bin/nvcc ] ||
    { echo "gpu-bundle.sh: nvcc not found (the bundle needs the CUDA backend)" >&2; exit 1; }
  cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DVSD_CUDA=ON \
        -DVSD_CUDA_ARCHITECTURES="90-real;90-virtual" -DVSD_BLENDER_TESTS=OFF
  cmake --build build-gpu -j"$(nproc)" --target vsd vsd-core test_cuda bench_device
fi

rm -rf "$stage" "$bundle"
mkdir -p "$stage/bin" "$stage/lib" "$stage/data" "$bundle"
for p in "${programs[@]}"; do
  [ -x "build-gpu/$p" ] || { echo "gpu-bundle.sh: build-gpu/$p is missing (build first)" >&2; exit 1; }
  cp "build-gpu/$p" "$stage/bin/"
done

# glibc's own libraries come from the GPU machine; everything else travels. ldd lists the
# whole dependency closure, so one pass over the executables finds every library.
is_glibc() {
  case "$(basename "$1")" in
    libc.so.*|libm.so.*|libpthread.so.*|libdl.so.*|librt.so.*|ld-linux*.so.*|linux-vdso.so.*) return 0 ;;
  esac
  return 1
}
for p in "$stage"/bin/*; do
  ldd "$p" | awk '/=>/ { print $1, $3 } !/=>/ && $1 ~ /^\// { print $1, $1 }'
done | sort -u | while read -r soname path; do
  is_glibc "$soname" && continue
  [ -f "$path" ] || { echo "gpu-bundle.sh: $soname not found by ldd" >&2; exit 1; }
  cp -L "$path" "$stage/lib/$soname"
done

for f in "${data_files[@]}"; do
  [ -f "$data_src/$f" ] || { echo "gpu-bundle.sh: data file $data_src/$f is missing" >&2; exit 1; }
  mkdir -p "$stage/data/$(dirname "$f")"
  cp "$data_src/$f" "$stage/data/$f"
done

raw=$(du -sb "$stage" | cut -f1)
tar -C "$stage" -cf - bin lib data | xz -T0 -6 > "$bundle/vsd-gpu.tar.xz"
(cd "$bundle" && sha256sum vsd-gpu.tar.xz > vsd-gpu.tar.xz.sha256)
size=$(stat -c %s "$bundle/vsd-gpu.tar.xz")
awk -v f="$bundle/vsd-gpu.tar.xz" -v s="$size" -v r="$raw" -v l="$(ls "$stage/lib" | wc -l)" \
    -v d="${#data_files[@]}" 'BEGIN { printf "bundle: %s: %.1f MiB (raw %.1f MiB: %d libraries, %d data files)\n", f, s / 1048576, r / 1048576, l, d }'
if [ "$size" -gt $((max_mib * 1048576)) ]; then
  echo "gpu-bundle.sh: the bundle is over ${max_mib} MiB; the GPU machine takes 64 MiB with the tree" >&2
  exit 1
fi
rm -rf "$stage"

[ "$check" -eq 1 ] || exit 0

# Self-check: unpack into an empty folder and run from there with a bare environment, so
# nothing from this machine (its LD_LIBRARY_PATH, $VSD_SHARED_DATA, the build tree) leaks in.
probe=$(mktemp -d)
trap 'rm -rf "$probe"' EXIT
xz -dc "$bundle/vsd-gpu.tar.xz" | tar -C "$probe" -xf -
outside=$(env -i LD_LIBRARY_PATH="$probe/lib" ldd "$probe/bin/vsd" "$probe/bin/vsd-core" "$probe/bin/test_cuda" "$probe/bin/bench_device" |
          awk '/=>/ { print $1, $3 }' | while read -r soname path; do
            is_glibc "$soname" || case "$path" in "$probe"/lib/*) ;; *) echo "$soname => $path" ;; esac
          done)
if [ -n "$outside" ]; then
  echo "gpu-bundle.sh: libraries resolved outside the bundle:" >&2
  echo "$outside" >&2
  exit 1
fi
(cd "$probe" && env -i LD_LIBRARY_PATH="$probe/lib" HOME="$probe" "$probe/bin/vsd" render \
   data/scenes/smoke64_sunset.json --frames 24-24 --width 64 --height 36 --samples 4 --device cpu \
   --output out/check_####.exr --quiet)
[ -s "$probe/out/check_0024.exr" ] || { echo "gpu-bundle.sh: the self-check render wrote no EXR" >&2; exit 1; }
set +e
(cd "$probe" && env -i LD_LIBRARY_PATH="$probe/lib" VSD_SHARED_DATA="$probe/data" "$probe/bin/test_cuda" >/dev/null 2>&1)
rc=$?
set -e
case $rc in
  0|77) echo "self-check: vsd render from the unpacked bundle under env -i wrote out/check_0024.exr; test_cuda exit $rc" ;;
  *) echo "gpu-bundle.sh: test_cuda from the bundle exited $rc" >&2; exit 1 ;;
esac
