#!/bin/bash
# method-images.sh OUTDIR [VSD] — renders every registered method on a few scenes of
# different character (smoke, fire with emission, a cloud in an interior map) at a small
# size, into OUTDIR/<scene>_<method>.exr. Run it before and after a change that must not
# change images, then compare the two folders pass by pass: idiff -fail 0 A B for each file
# (the EXR headers differ in their metadata; the pixels must not).
set -euo pipefail
out=${1:?usage: method-images.sh OUTDIR [VSD]}
vsd=${2:-build/vsd}
root=$(cd "$(dirname "$0")/.." && pwd)
shared=${VSD_SHARED:-$root/../shared}
mkdir -p "$out"
methods=${METHODS:-$("$vsd" methods --names)}
scenes=("$root/examples/smoke/smoke.json" "$shared/data/scenes/fire96_studio.json"
        "$shared/data/scenes/cloud128_interior.json")
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .json)
    for m in $methods; do
        "$vsd" render "$scene" --quiet --method "$m" --width 160 --height 90 --samples 16 --threads 2 \
            --output "$out/${name}_$m.exr" --cache-dir none
    done
done
