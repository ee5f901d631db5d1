#!/usr/bin/env bash
# vsd smoke in a POV-Ray scene (docs/povray.md): export, render in POV-Ray, composite.
# Run from anywhere: ./run.sh [VSD] (default: vsd on PATH, else ../../../build/vsd).
# Writes into ./out/ beside this script. Needs povray 3.7.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
vsd=${1:-$(command -v vsd || echo "$here/../../../build/vsd")}
scene=$here/../../../../shared/data/scenes/smoke64_sunset.json   # the shared test data
out=$here/out
W=320 H=180 FRAME=24
mkdir -p "$out"

# 1. the volume, medium and camera as POV-Ray files (out/pov/smoke64_sunset.*)
"$vsd" export pov "$scene" --frames $FRAME "$out/pov"

cd "$out/pov"   # POV-Ray reads and writes only in its working folder
# 2a. POV-Ray renders the smoke itself, lit by its sun, shadowing the floor
povray smoke64_sunset.ini +W$W +H$H -D
# 2b. a plate: the floor with the smoke's shadow, the smoke itself unseen ...
povray smoke64_sunset.ini +W$W +H$H -D Declare=vsd_plate=1 +Oplate_
# 2c. ... and its depth (POV-Ray writes no Z channel: vsd_depth_texture does)
povray smoke64_sunset.ini +W$W +H$H -D Declare=vsd_depth_pass=1 +Odepth_

# 3. vsd's own render of the same frame, transparent, then over the plate by depth
"$vsd" render "$scene" --frames $FRAME --width $W --height $H --set film.transparent=true \
  --output "$out/vsd_####.exr"
"$vsd" composite "$out/vsd_$(printf %04d $FRAME).exr" "plate_$FRAME.exr" "$out/composite_$FRAME.exr" \
  --plate-depth "depth_$FRAME.exr"
echo "POV-Ray's smoke: $out/pov/smoke64_sunset_pov_$FRAME.exr"
echo "vsd over POV-Ray: $out/composite_$FRAME.exr"
