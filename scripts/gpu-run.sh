#!/usr/bin/env bash
# Runs on the GPU machine, from the repository root, with build-gpu/bundle carried along
# (scripts/gpu-bundle.sh made it): unpacks the bundle, prints nvidia-smi and the driver,
# runs test_cuda, then bench_device at 1280x720 within a time budget, and a vsd render on
# CUDA. Full logs and the markdown table go to $OUT (or gpu-out/ where $OUT is unset); the
# output ends with the short table, since only the end of it comes back from that machine.
#
# Usage: scripts/gpu-run.sh [--bench-seconds S] [-- extra bench_device options]
# Exit: 0 when test_cuda passed and the benchmark ran; 77 when no CUDA device answers
# (saying so, after the table header); 1 when something failed.
set -uo pipefail
cd "$(dirname "$0")/.."

bench_seconds=300
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --bench-seconds) bench_seconds=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "gpu-run.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done

tarball=build-gpu/bundle/vsd-gpu.tar.xz
out=${OUT:-$PWD/gpu-out}
mkdir -p "$out"
[ -f "$tarball" ] || { echo "gpu-run.sh: $tarball is missing: run scripts/gpu-bundle.sh here and carry build-gpu/bundle" >&2; exit 1; }
if [ -f "$tarball.sha256" ] && ! (cd build-gpu/bundle && sha256sum -c --quiet vsd-gpu.tar.xz.sha256); then
  echo "gpu-run.sh: $tarball does not match its checksum (a broken transfer?)" >&2; exit 1
fi

root=$(mktemp -d)
xz -dc "$tarball" | tar -C "$root" -xf - || { echo "gpu-run.sh: could not unpack $tarball" >&2; exit 1; }
export LD_LIBRARY_PATH="$root/lib"
export VSD_SHARED_DATA="$root/data"
summary="$out/summary.md"
: > "$summary"

{
  echo "== machine"
  uname -srm
  if command -v nvidia-smi >/dev/null; then
    nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv
    nvidia-smi
  else
    echo "nvidia-smi: not found"
  fi
} 2>&1 | tee "$out/machine.log"
gpu=$(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null | head -1)

echo "== test_cuda"
start=$(date +%s)
"$root/bin/test_cuda" > "$out/test_cuda.log" 2>&1
test_rc=$?
echo "test_cuda: exit $test_rc in $(( $(date +%s) - start )) s (log: test_cuda.log)"
tail -n 30 "$out/test_cuda.log"

echo "== bench_device --width 1280 --height 720 --max-seconds $bench_seconds ${extra[*]:-}"
start=$(date +%s)
"$root/bin/bench_device" --width 1280 --height 720 --max-seconds "$bench_seconds" "${extra[@]}" \
    > "$out/bench_device.md" 2> "$out/bench_device.log"
bench_rc=$?
echo "bench_device: exit $bench_rc in $(( $(date +%s) - start )) s (table: bench_device.md)"

render_rc=skipped
if [ "$test_rc" -ne 77 ]; then
  echo "== vsd render on CUDA"
  (cd "$root" && "$root/bin/vsd" render data/scenes/smoke64_sunset.json --device cuda --frames 24-24 \
       --width 1280 --height 720 --samples 16 --output "$out/render_####.exr" --quiet) > "$out/render.log" 2>&1
  render_rc=$?
  cat "$out/render.log"
fi

{
  echo "GPU: ${gpu:-none}; test_cuda exit $test_rc; bench_device exit $bench_rc; vsd render --device cuda: $render_rc"
  echo
  cat "$out/bench_device.md"
} > "$summary"
echo
echo "== summary (also $summary)"
cat "$summary"
rm -rf "$root"

if [ "$test_rc" -eq 77 ] || [ "$bench_rc" -eq 77 ]; then
  echo "gpu-run.sh: no CUDA device: $(grep -m1 -i 'no cuda device\|skip' "$out/test_cuda.log" || echo 'test_cuda skipped')"
  exit 77
fi
[ "$test_rc" -eq 0 ] && [ "$bench_rc" -eq 0 ] && [ "$render_rc" = 0 ]
