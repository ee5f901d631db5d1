#!/bin/bash
# ratio-images.sh OUT.png REF.exr A.exr [B.exr ...] — one row: the reference's Combined,
# then for each method image its Combined and its ratio to the reference (the Combined
# pass's green channel, method / reference) in false colour: grey = equal, orange = brighter
# (1.5x and above full), blue = darker (0.5x and below full); black where the reference's
# alpha is under 0.05 (no medium). Rows of several scenes stack with oiiotool --mosaic 1xN.
set -euo pipefail
out=${1:?usage: ratio-images.sh OUT.png REF.exr A.exr [B.exr ...]}
ref=${2:?reference EXR}
shift 2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
L=ViewLayer.Combined
srgb() { oiiotool "$1" --ch "R=$L.R,G=$L.G,B=$L.B" --colorconvert linear sRGB -d uint8 -o "$2"; }
srgb "$ref" "$tmp/0.png"
oiiotool "$ref" --ch "$L.A" --mulc 20 --clamp:min=0:max=1 -o "$tmp/mask.exr"
tiles=("$tmp/0.png")
i=0
for m in "$@"; do
    i=$((i + 1))
    srgb "$m" "$tmp/$i.png"
    oiiotool "$m" --ch "$L.G" --addc 1e-4 "$ref" --ch "$L.G" --addc 1e-4 --div -o "$tmp/r.exr"
    oiiotool "$tmp/r.exr" --subc 0.5 --clamp:min=0:max=1 "$tmp/mask.exr" --mul -o "$tmp/R.exr"
    oiiotool "$tmp/r.exr" --mulc 0 --addc 0.5 "$tmp/mask.exr" --mul -o "$tmp/G.exr"
    oiiotool "$tmp/r.exr" --mulc -1 --addc 1.5 --clamp:min=0:max=1 "$tmp/mask.exr" --mul -o "$tmp/B.exr"
    oiiotool "$tmp/R.exr" "$tmp/G.exr" --chappend "$tmp/B.exr" --chappend --chnames R,G,B -d uint8 -o "$tmp/$i.ratio.png"
    tiles+=("$tmp/$i.png" "$tmp/$i.ratio.png")
done
oiiotool "${tiles[@]}" --mosaic "${#tiles[@]}x1" -o "$out"
