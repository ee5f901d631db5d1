#!/usr/bin/env bash
# Issue 32's interactive targets in one run, so that docs/tte.md's table comes from one
# machine and one hour rather than from many (this VM's timings of one binary move by
# 15-35% between days):
#   1. every kind of edit of a kept renderer (bench_edits: camera, map rotation, map
#      strength, density, albedo, anisotropy, a new VDB frame) for lbl and crm on smoke128
#      frame 45 at 1280x720; the camera and the rotation on cloud256 too; the camera for
#      shgrid and constellation on both;
#   2. what `vsd render --remote` adds over the daemon's render (client_overhead.sh) for each
#      EXR compression;
#   3. the Blender 3.4 viewport under Xvfb at 264x166 and at the larger preview, when
#      VIEWPORT=1 (the ctest of the build dir, then the same test on a larger screen).
# Prints a markdown table per part; the raw logs stay in OUT.
# Usage: bench/tte/interactive.sh BUILD_DIR OUT   (env: VIEWPORT=1, CLIENT_RUNS=8)
# The machine should be idle but for it: every number is a wall-clock time.
set -u
B=$(cd "${1:?usage: interactive.sh BUILD_DIR OUT}" && pwd)
OUT=${2:?usage: interactive.sh BUILD_DIR OUT}
mkdir -p "$OUT" && OUT=$(cd "$OUT" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
scenes=$(cd "$here/../../../shared/data/scenes" && pwd)
S128=$scenes/smoke128_forest.json C256=$scenes/cloud256_sunset.json

# "median 0.393 s of 5 edits (0.359-0.419)" -> "0.393 (0.359-0.419)"
edit_cell() {
  sed -n 's/.*: median \([0-9.]*\) s of [0-9]* edits (\([0-9.-]*\))$/\1 (\2)/p' "$1" | tail -1
}

edits() {   # scene method edit count
  local log=$OUT/edits_$(basename "$1" .json)_$2_$3.log
  "$B/bench_edits" "$1" "$2" "$3" "$4" > "$log" 2>&1 || echo "bench_edits $*: failed (see $log)" >&2
  edit_cell "$log"
}

echo "## Edits of a kept renderer, 1280x720 (bench_edits; seconds: median (min-max) of the edits)"
echo
echo "| scene | edit | lbl | crm | target |"
echo "|---|---|---|---|---|"
for e in camera:7:0.15 rotation:3:0.5 strength:3:0.5 density:3:0.5 albedo:3:0.5 g:3:0.5 frame:4:1.5; do
  IFS=: read -r edit n target <<< "$e"
  echo "| smoke128 f45 | $edit | $(edits "$S128" lbl "$edit" "$n") | $(edits "$S128" crm "$edit" "$n") | ≤ $target |"
done
for e in camera:5:0.15 rotation:3:0.5; do
  IFS=: read -r edit n target <<< "$e"
  echo "| cloud256 | $edit | $(edits "$C256" lbl "$edit" "$n") | $(edits "$C256" crm "$edit" "$n") | ≤ $target |"
done
echo
echo "| scene | edit | shgrid | constellation | target |"
echo "|---|---|---|---|---|"
for s in "$S128" "$C256"; do
  echo "| $(basename "$s" .json) | camera | $(edits "$s" shgrid camera 5) | $(edits "$s" constellation camera 5) | ≤ 0.5 |"
done

echo
echo "## The client: \`vsd render --remote\` over the daemon's render (lbl, smoke128 f45, 1280x720)"
echo
for comp in rle none zip; do
  FRESH=1 COMP=$comp CLIENTS=vsd RUNS=${CLIENT_RUNS:-8} bash "$here/../daemon/client_overhead.sh" "$B" \
    > "$OUT/client_$comp.log" 2>&1
  echo "* \`output.compression\` $comp: $(grep '^vsd ' "$OUT/client_$comp.log" || echo "failed (see $OUT/client_$comp.log)")"
done

if [ -n "${VIEWPORT:-}" ]; then
  echo
  echo "## The Blender 3.4 viewport under Xvfb (tests/blender_addon/test_viewport.py's preview benchmark)"
  for screen in 1280x800x24 2800x1700x24; do
    log=$OUT/viewport_$screen.log
    xvfb-run -a -s "-screen 0 $screen" blender --factory-startup --python-exit-code 1 \
      --python "$here/../../tests/blender_addon/test_viewport.py" -- "$B/vsd" "$scenes/.." "$OUT/viewport_$screen" \
      > "$log" 2>&1 || echo "viewport on $screen: the test failed (see $log)"
    echo
    echo "screen $screen:"
    grep "preview benchmark" "$log" | sed 's/^/    /'
  done
fi
