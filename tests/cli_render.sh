#!/usr/bin/env bash
# End-to-end checks of `vsd render`: the README's example renders to a multilayer EXR with
# Blender's channel names plus a PNG preview; bad input exits 3 with a message naming the
# problem; a bad command line exits 2; overrides reach the renderer.
# Usage: cli_render.sh VSD SOURCE_DIR TMP_DIR
set -u
vsd=$1 src=$2 tmp=$3/cli_render
rm -rf "$tmp" && mkdir -p "$tmp"
fail=0
check() { if ! eval "$2"; then echo "FAIL: $1" >&2; fail=1; fi; }

# 1. the example, small and fast, written where we say
out=$("$vsd" render "$src/examples/smoke/smoke.json" --width 64 --height 36 --samples 4 \
      --output "$tmp/ex_####.exr" --preview "$tmp/ex_####.png" 2>"$tmp/err"); rc=$?
check "example renders (rc $rc: $(cat "$tmp/err"))" '[ $rc -eq 0 ]'
check "EXR written" '[ -s "$tmp/ex_0024.exr" ]'
check "PNG written" '[ -s "$tmp/ex_0024.png" ]'
check "no temporary files left" '[ -z "$(ls "$tmp" | grep tmp)" ]'
check "summary line" 'echo "$out" | grep -q "frame 24: .*ex_0024.exr.*reference, 4 spp"'
if command -v oiiotool >/dev/null; then
  info=$(oiiotool --info -v "$tmp/ex_0024.exr")
  for ch in ViewLayer.Combined.R ViewLayer.Combined.A ViewLayer.VolumeDir.G ViewLayer.VolumeInd.B \
            ViewLayer.Emit.R ViewLayer.Transmittance.G ViewLayer.Depth.Z; do
    check "channel $ch" 'echo "$info" | grep -q "$ch"'
  done
  check "64x36" 'echo "$info" | grep -Eq "64 x +36"'
  check "method attribute" 'echo "$info" | grep -q "vsd/method: \"reference\""'
fi

# 2. bad input: exit 3, message names the field / file
printf '{"version":1,"volume":{"file":"x.vdb"},"camera":{"fov":"wide"}}' > "$tmp/bad.json"
"$vsd" render "$tmp/bad.json" 2>"$tmp/err"; rc=$?
check "wrong type exits 3 (got $rc)" '[ $rc -eq 3 ]'
check "wrong type names camera.fov" 'grep -q "camera.fov: expected number" "$tmp/err"'
printf '{"version":1,"volume":{"file":"missing_####.vdb"},"film":{"width":8,"height":8}}' > "$tmp/missing.json"
"$vsd" render "$tmp/missing.json" --output "$tmp/m.exr" 2>"$tmp/err"; rc=$?
check "missing VDB exits 3 (got $rc)" '[ $rc -eq 3 ]'
check "missing VDB named" 'grep -q "missing_0001.vdb" "$tmp/err"'
"$vsd" render "$src/examples/smoke/smoke.json" --method nosuch 2>"$tmp/err"; rc=$?
check "unknown method exits 3 (got $rc)" '[ $rc -eq 3 ]'
check "unknown method lists methods" 'grep -q "unknown method .nosuch. (available: reference, raymarch" "$tmp/err"'
"$vsd" render "$src/examples/smoke/smoke.json" --width 100000 2>"$tmp/err"; rc=$?
check "absurd resolution exits 3 (got $rc)" '[ $rc -eq 3 ]'
check "absurd resolution named" 'grep -q "film.width" "$tmp/err"'

# 3. bad command line: exit 2
"$vsd" render 2>/dev/null; rc=$?
check "no scene exits 2 (got $rc)" '[ $rc -eq 2 ]'
"$vsd" render "$src/examples/smoke/smoke.json" --frobnicate 1 2>"$tmp/err"; rc=$?
check "unknown flag exits 2 (got $rc)" '[ $rc -eq 2 ]'
"$vsd" render "$src/examples/smoke/smoke.json" --frames x-y 2>"$tmp/err"; rc=$?
check "bad --frames exits 2 (got $rc)" '[ $rc -eq 2 ]'

# 4. frame ranges and --set: two frames of smoke64 from the shared data, raymarch, quiet
"$vsd" render "$src/../shared/data/scenes/smoke64_sunset.json" --frames 2-3 --width 16 --height 9 \
   --method raymarch --set render.options.lights=4 --output "$tmp/seq_####.exr" --quiet >"$tmp/out" 2>&1; rc=$?
check "sequence renders (rc $rc)" '[ $rc -eq 0 ]'
check "frames 2 and 3 written" '[ -s "$tmp/seq_0002.exr" ] && [ -s "$tmp/seq_0003.exr" ] && [ ! -e "$tmp/seq_0001.exr" ]'
check "--quiet prints nothing" '[ ! -s "$tmp/out" ]'

exit $fail
