#!/usr/bin/env bash
# `vsd render` as a POV-Ray-style pipeline drives it (docs/pipeline.md): INI files with
# POV-Ray's keys and [Section]s, +switches and Key=Value on the command line, the order
# command line > INI > scene file, errors naming the INI line, subsets, and --continue
# (+C, Continue_Trace) skipping exactly the frames whose EXR is complete for this scene,
# after a kill -9 mid-frame, a truncated file, a changed scene and a leftover temporary.
# Usage: pipeline_render.sh VSD SOURCE_DIR TMP_DIR
set -u
vsd=$1 src=$2 tmp=$3/pipeline_render
scene="$src/../shared/data/scenes/smoke64_sunset.json"
rm -rf "$tmp" && mkdir -p "$tmp/job" && cd "$tmp"
fail=0
check() { if ! eval "$2"; then echo "FAIL: $1" >&2; fail=1; fi; }
attr() { oiiotool --info -v "$1" | sed -n "s|^ *$2: ||p" | tr -d '"'; }
size() { oiiotool --info "$1" | grep -Eo '[0-9]+ x +[0-9]+' | tr -d ' '; }

# 1. An INI file with POV-Ray's keys; its paths are relative to its own folder.
cat > job/job.ini <<EOF
; POV-Ray keys, a vsd scene field, and a section
Input_File_Name = "$scene"
Output_File_Name=out/
Width=48
Height=27   ; a comment after a value
Initial_Frame=1
Final_Frame=6
Subset_Start_Frame=2
Subset_End_Frame=4
Antialias=on
Antialias_Depth=2
render.seed=7
Output_File_Type=E

[Wide]
Width=96
+H54
EOF
"$vsd" render job/job.ini >out.txt 2>err.txt; rc=$?
check "INI renders (rc $rc: $(head -c 300 err.txt))" '[ $rc -eq 0 ]'
check "Output_File_Name folder: <scene>_####.exr beside the INI, subset 2-4 only" \
  '[ -s job/out/smoke64_sunset_0002.exr ] && [ -s job/out/smoke64_sunset_0004.exr ] && [ ! -e job/out/smoke64_sunset_0001.exr ] && [ ! -e job/out/smoke64_sunset_0005.exr ]'
check "Width/Height 48x27 (got $(size job/out/smoke64_sunset_0002.exr))" '[ "$(size job/out/smoke64_sunset_0002.exr)" = "48x27" ]'
check "Antialias_Depth=2 is 4 samples" '[ "$(attr job/out/smoke64_sunset_0002.exr vsd/samples)" = 4 ]'
check "log lines carry the run position" 'grep -q "^done 3/3 frames" err.txt && grep -q "^frame 3 (2/3) " err.txt'
check "ETA on the second frame" 'grep -q "^done 2/3 frames (elapsed [0-9]*s, ETA" err.txt'

# 2. A section; switches and Key=Value on the command line win over the INI.
"$vsd" render 'job/job.ini[wide]' --frames 2 -q; rc=$?
check "section [Wide] (rc $rc): 96x54 (got $(size job/out/smoke64_sunset_0002.exr))" '[ "$(size job/out/smoke64_sunset_0002.exr)" = "96x54" ]'
"$vsd" render job/job.ini +W32 Height=18 +KFI2 +KFF3 +SF2 +EF2 +R1 +O"$tmp/cl_####.exr" -q; rc=$?
check "switches over INI (rc $rc): 32x18, 1 sample, frame 2 only" \
  '[ "$(size cl_0002.exr)" = "32x18" ] && [ "$(attr cl_0002.exr vsd/samples)" = 1 ] && [ ! -e cl_0003.exr ]'
"$vsd" render job/job.ini -A --frames 5 --set film.width=40 --output "$tmp/a_####.exr" -q
check "-A is one sample; --set over INI; --frames replaces the subset" \
  '[ "$(attr a_0005.exr vsd/samples)" = 1 ] && [ "$(size a_0005.exr)" = "40x27" ]'
"$vsd" render job/job.ini +SF0.0 +EF0.2 --output "$tmp/f_####.exr" -q
check "fractional subset 0.0-0.2 of frames 1-6 is frames 1-2" '[ -s f_0001.exr ] && [ -s f_0002.exr ] && [ ! -e f_0003.exr ]'

# 3. Errors name the file and line, or the switch.
printf 'Width=32\nQuality=9\n' > bad.ini
"$vsd" render bad.ini "$scene" 2>err.txt; rc=$?
check "unknown INI key exits 3 (got $rc) naming file:line" '[ $rc -eq 3 ] && grep -q "bad.ini:2: unknown key .Quality." err.txt'
printf 'Width=wide\n' > bad2.ini
"$vsd" render bad2.ini "$scene" 2>err.txt; rc=$?
check "bad value names the line" '[ $rc -eq 3 ] && grep -q "bad2.ini:1: Width: expected a whole number, got .wide." err.txt'
"$vsd" render "$scene" +Q9 2>err.txt; rc=$?
check "unknown switch exits 2 (got $rc)" '[ $rc -eq 2 ] && grep -q "unknown switch .+Q9." err.txt'
"$vsd" render 'job/job.ini[Nope]' 2>err.txt; rc=$?
check "missing section named" '[ $rc -eq 3 ] && grep -q "no section \[Nope\]" err.txt'
printf 'Width=32\n' > noinput.ini
"$vsd" render noinput.ini 2>err.txt; rc=$?
check "INI without Input_File_Name and no scene: exit 2" '[ $rc -eq 2 ] && grep -q "no Input_File_Name" err.txt'
"$vsd" render job/job.ini +SF9 2>err.txt; rc=$?
check "subset outside the sequence named" '[ $rc -eq 3 ] && grep -q "subset 9-4 .*not inside the sequence 1-6" err.txt'
"$vsd" render job/job.ini Output_File_Type=N 2>err.txt; rc=$?
check "non-EXR output type refused" '[ $rc -eq 2 ] && grep -q "OpenEXR only" err.txt'

# 4. --continue after kill -9 mid-frame: frames big enough to take a moment.
run=(render "$scene" --frames 1-4 --width 320 --height 180 --samples 32 --output "$tmp/seq/s_####.exr")
"$vsd" "${run[@]}" -q &
pid=$!
for _ in $(seq 1 300); do [ -e seq/s_0002.exr ] && break; sleep 0.05; done
kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null
check "killed while frame 3 rendered (frame 2 done, 4 not)" '[ -s seq/s_0002.exr ] && [ ! -e seq/s_0004.exr ]'
check "a killed run leaves no frame 3 that --continue would accept" '[ ! -e seq/s_0003.exr ]'
: > seq/s_0004.exr.tmp-99999               # a killed writer's leftover
head -c 2000 seq/s_0002.exr > seq/trunc && mv seq/trunc seq/s_0002.exr  # a damaged frame
m1=$(stat -c %Y.%i seq/s_0001.exr)
sleep 1.1
"$vsd" "${run[@]}" --continue >out.txt 2>err.txt; rc=$?
check "resumed run succeeds (rc $rc)" '[ $rc -eq 0 ]'
check "frame 1 skipped and untouched" 'grep -q "^frame 1: skipped, complete" err.txt && [ "$(stat -c %Y.%i seq/s_0001.exr)" = "$m1" ]'
check "truncated frame 2 renders again, named" 'grep -q "^frame 2: renders again: .*read" err.txt && grep -q "^frame 2: " out.txt'
check "counts reported" 'grep -q -- "--continue: 1 of 4 frames complete and skipped; 3 to render (2 missing, 1 broken, 0 from another scene)" err.txt'
check "only frames 2-4 rendered" '[ "$(grep -c "^frame [0-9]*: .*s_000" out.txt)" = 3 ] && ! grep -q "^frame 1: " out.txt'
check "ETA counts only the 3 frames to render" 'grep -q "^done 3/3 frames" err.txt'
"$vsd" "${run[@]}" --output "$tmp/whole/s_####.exr" -q
for f in 1 2 3 4; do
  check "frame $f: every pixel of every pass equals an uninterrupted run" \
    'idiff -fail 0 -failpercent 0 "seq/s_000$f.exr" "whole/s_000$f.exr" >/dev/null'
done
"$vsd" "${run[@]}" +C --set medium.density=4 -q 2>err.txt
check "changed scene: every frame renders again" '[ "$(attr seq/s_0001.exr vsd/frame)" = 1 ] && [ "$(stat -c %Y.%i seq/s_0001.exr)" != "$m1" ]'
"$vsd" "${run[@]}" --set medium.density=4 --threads 1 --continue 2>err.txt >out.txt
check "thread count and frame range do not change the scene hash" \
  'grep -q "4 of 4 frames complete and skipped" err.txt && [ ! -s out.txt ]'
printf 'Continue_Trace=on\n' > cont.ini
"$vsd" "${run[@]}" cont.ini --set medium.density=4 2>err.txt >out.txt
check "Continue_Trace=on in an INI resumes" 'grep -q "4 of 4 frames complete and skipped" err.txt'

# 5. Frames a daemon rendered (--remote) carry the same scene hash: a local --continue
#    skips them (the daemon hashes its copies of the uploaded files).
"$vsd" serve --socket "$tmp/d.sock" --cache-dir "$tmp" >daemon.log 2>&1 &
dpid=$!
for _ in $(seq 1 100); do [ -S "$tmp/d.sock" ] && break; sleep 0.05; done
"$vsd" render "$scene" --frames 2-3 --width 32 --height 18 --samples 2 --output "$tmp/rem/r_####.exr" \
  --remote="$tmp/d.sock" -q; rc=$?
kill $dpid; wait $dpid 2>/dev/null
check "remote render (rc $rc)" '[ $rc -eq 0 ] && [ -s rem/r_0003.exr ]'
"$vsd" render "$scene" --frames 1-3 --width 32 --height 18 --samples 2 --output "$tmp/rem/r_####.exr" \
  --continue 2>err.txt >out.txt
check "local --continue skips the daemon's frames" \
  'grep -q "^frame 2: skipped, complete" err.txt && grep -q "^frame 3: skipped, complete" err.txt && grep -q "^frame 1: " out.txt'

# 6. --max-voxels: the scene's density grids together, checked before loading; a bad value
#    is a usage error naming the flag.
"$vsd" render "$scene" --frames 2 --width 16 --height 9 --samples 1 --output "$tmp/mv/m_####.exr" \
  --max-voxels 1000 -q 2>err.txt; rc=$?
check "--max-voxels 1000 refuses frame 2 (rc $rc: $(head -c 300 err.txt))" \
  '[ $rc -ne 0 ] && grep -q "active voxels; the limit is 1000 (vsd render --max-voxels)" err.txt && [ ! -e mv/m_0002.exr ]'
"$vsd" render "$scene" --frames 2 --width 16 --height 9 --samples 1 --output "$tmp/mv/m_####.exr" \
  --max-voxels 1e9 -q 2>err.txt; rc=$?
check "--max-voxels 1e9 renders (rc $rc)" '[ $rc -eq 0 ] && [ -s mv/m_0002.exr ]'
"$vsd" render "$scene" --max-voxels many -q 2>err.txt; rc=$?
check "--max-voxels many is a usage error (rc $rc)" '[ $rc -eq 2 ] && grep -q "^vsd render: --max-voxels: .many. is not a whole number" err.txt'

exit $fail
