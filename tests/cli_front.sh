#!/usr/bin/env bash
# The `vsd` front (service/front/vsd_front.c): `vsd render --remote` runs in a process that
# loads none of the renderer's libraries and needs no vsd-core at all; every other command
# (and --remote with --continue or --help) runs in vsd-core, found beside vsd (a build
# folder) or in ../libexec/vsd (an installation), or fails naming what is missing.
# Usage: cli_front.sh VSD VSD_CORE SOURCE_DIR TMP_DIR
set -u
vsd=$1 core=$2 src=$3 tmp=$4/cli_front
scene="$src/../shared/data/scenes/smoke64_sunset.json"
rm -rf "$tmp" && mkdir -p "$tmp" && cd "$tmp"
fail=0
check() { if ! eval "$2"; then echo "FAIL: $1" >&2; fail=1; fi; }

# 1. What the front loads: the client's few libraries, none of the renderer's.
readelf -d "$vsd" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' > needed.txt
check "readelf lists the front's libraries ($(tr '\n' ' ' < needed.txt))" 'grep -q "^libcjson" needed.txt'
heavy=$(grep -Ei 'openvdb|tbb|OpenColorIO|OpenEXR|Iex|Imath|openblas|lapack|nlopt|chealpix|cuda|boost|png|stdc\+\+' needed.txt)
check "the front links no renderer library (found: $heavy)" '[ -z "$heavy" ]'
readelf -d "$core" | grep -q 'openvdb' || { echo "FAIL: vsd-core should link OpenVDB (is \$2 vsd-core?)" >&2; fail=1; }

# 2. Other commands go to vsd-core: the same answers as vsd-core itself.
check "vsd --version is vsd-core's" '[ "$("$vsd" --version)" = "$("$core" --version)" ] && [ -n "$("$vsd" --version)" ]'
"$vsd" render --remote --help > help.txt 2>&1; rc=$?
check "render --remote --help prints the usage with the methods (rc $rc)" '[ $rc -eq 0 ] && grep -q "render.method (reference" help.txt'
"$vsd" render --remote > usage.txt 2>&1; rc=$?
check "render --remote without a scene: usage, exit 2 (rc $rc)" '[ $rc -eq 2 ] && grep -q "^usage: vsd render" usage.txt'
"$vsd" render --remote --bogus "$scene" > bad.txt 2>&1; rc=$?
check "an unknown option is named once, exit 2 (rc $rc)" \
  '[ $rc -eq 2 ] && [ "$(grep -c "unknown option .--bogus." bad.txt)" = 1 ]'
"$vsd" render "$scene" --remote="$tmp/none.sock" --frames 24 -q > nosock.txt 2>&1; rc=$?
check "no daemon: exit 1, naming the socket (rc $rc)" '[ $rc -eq 1 ] && grep -q "none.sock" nosock.txt'

# 3. A remote render from a vsd alone in its folder (no vsd-core beside it, none installed)
#    is the same file as one from the build's vsd; any other command names what is missing.
mkdir -p alone cache
cp "$vsd" alone/vsd
"$vsd" serve --socket "$tmp/d.sock" --cache-dir "$tmp/cache" > daemon.log 2>&1 &
dpid=$!
for _ in $(seq 1 100); do [ -S "$tmp/d.sock" ] && break; sleep 0.05; done
common=(render "$scene" --width 32 --height 18 --samples 2 --method raymarch --remote="$tmp/d.sock")
alone/vsd "${common[@]}" --frames 24 -q --output "$tmp/a/r_####.exr" > alone.txt 2>&1; rc_a=$?
"$vsd" "${common[@]}" --frames 24 -q --output "$tmp/b/r_####.exr" > built.txt 2>&1; rc_b=$?
check "remote render without vsd-core (rc $rc_a: $(head -c 300 alone.txt))" '[ $rc_a -eq 0 ] && [ -s a/r_0024.exr ]'
check "remote render through the build's vsd (rc $rc_b)" '[ $rc_b -eq 0 ] && [ -s b/r_0024.exr ]'
check "the two are the same pixels" 'idiff -fail 0 -warn 0 a/r_0024.exr b/r_0024.exr > cmp.txt 2>&1'
# --continue reads the EXR already written (vsd-core): frame 24 skipped, 23 rendered remotely.
"$vsd" "${common[@]}" --frames 23-24 --continue --output "$tmp/b/r_####.exr" > cont.txt 2>&1; rc=$?
check "remote --continue skips the complete frame (rc $rc: $(head -c 300 cont.txt))" \
  '[ $rc -eq 0 ] && grep -q "^frame 24: skipped" cont.txt && [ -s b/r_0023.exr ]'
kill $dpid; wait $dpid 2>/dev/null
alone/vsd info "$scene" > missing.txt 2>&1; rc=$?
check "without vsd-core other commands fail naming it (rc $rc: $(head -c 300 missing.txt))" \
  '[ $rc -eq 1 ] && grep -q "vsd-core" missing.txt && grep -q "libexec/vsd" missing.txt'

# 4. The installed layout: bin/vsd finds ../libexec/vsd/vsd-core.
mkdir -p inst/bin inst/libexec/vsd
cp "$vsd" inst/bin/vsd && cp "$core" inst/libexec/vsd/vsd-core
check "bin/vsd runs ../libexec/vsd/vsd-core" '[ "$(inst/bin/vsd --version)" = "$("$core" --version)" ]'

[ $fail -eq 0 ] && echo "cli_front: all checks passed"
exit $fail
