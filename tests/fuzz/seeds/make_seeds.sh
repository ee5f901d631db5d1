#!/usr/bin/env bash
# Regenerates tests/fuzz/corpus/ seeds from scratch (the committed corpora also hold inputs
# the fuzzers found and minimised; this script does not touch those). Needs g++, OpenVDB
# headers, oiiotool and ../shared/data. Usage: tests/fuzz/seeds/make_seeds.sh
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
corpus=$here/../corpus
data=${VSD_SHARED_DATA:-$here/../../../../shared/data}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

mkdir -p "$corpus/vdb" "$corpus/env"
g++ -std=c++17 -O1 "$here/make_vdb_seeds.cpp" -o "$tmp/make_vdb_seeds" -lopenvdb -ltbb -lImath-3_1
"$tmp/make_vdb_seeds" "$corpus/vdb"
cp "$data/external/usd_smoke_000001.vdb" "$data/external/arnold_torus01.vdb" "$corpus/vdb/"

cd "$corpus/env"
for c in none rle zips zip piz pxr24 b44 b44a dwaa dwab; do
  oiiotool "$data/env/sunset.exr" --resize 16x8 -d half --compression $c -o sunset16_$c.exr
done
oiiotool "$data/env/studio.exr" --resize 8x4 -d float --compression zip -o studio8_float.exr
oiiotool "$data/env/forest.exr" --resize 16x8 -d half --tile 8 8 --compression zip -o forest16_tiled.exr
oiiotool "$data/env/sunset.exr" --resize 8x4 -d half --ch R,G,B,A=1.0 \
  --chnames "ViewLayer.Combined.R,ViewLayer.Combined.G,ViewLayer.Combined.B,ViewLayer.Combined.A" \
  --attrib "vsd/scene_hash" "0123abcd" --compression zip -o multilayer8.exr
oiiotool "$data/env/sunset.exr" --resize 8x4 -d half --ch R --chnames Y --compression none -o gray8.exr
oiiotool "$data/env/sunset.exr" --resize 8x4 -d float --compression piz --origin +3+2 -o window8.exr
oiiotool "$data/env/interior.hdr" --resize 16x8 -o interior16.hdr
oiiotool "$data/env/StinsonBeach.hdr" --resize 4x2 -o stinson4.hdr
printf '#?RGBE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n-Y 2 +X 2\n\x80\x40\x20\x81\x10\x10\x10\x7f\x00\x00\x00\x00\xff\xff\xff\x88' > flat2.hdr

VSD_SHARED_DATA=$data python3 "$here/make_seeds.py" "$corpus"
chmod 644 "$corpus"/*/*
