#!/usr/bin/env bash
# What `vsd render --remote` adds over the daemon's render (issue 32's 0.25 s target): wall
# time of the client process minus the result's `vsd/render_seconds`, for each client
# executable in CLIENTS (default: the light front `vsd` and `vsd-core`, which is the old
# one-binary client: the same code with every renderer library loaded), interleaved so
# that the machine's load hits both alike. One warm daemon; the camera moves per request so
# nothing is a cache hit; RUNS requests per client after one warm-up each.
# Usage: bench/daemon/client_overhead.sh [BUILD_DIR]   (env: RUNS=10 M=lbl COMP=none FRESH=1)
#   FRESH=1 writes each result to a new file (a sequence's frames); unset, every request
#   replaces the same file (ext4 then writes the new file's blocks out on the rename).
set -u
B=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
S=$here/../../../shared/data/scenes/smoke128_forest.json
M=${M:-lbl} COMP=${COMP:-none} RUNS=${RUNS:-10} CLIENTS=${CLIENTS:-vsd vsd-core}
D=$(mktemp -d); SOCK=$D/vsd.sock
trap 'kill $SP 2>/dev/null; wait $SP 2>/dev/null; rm -rf "$D"' EXIT
"$B/vsd" serve --socket "$SOCK" --cache-dir "$D" --allow-path "$(dirname "$(dirname "$S")")" > "$D/serve.log" 2>&1 &
SP=$!
for _ in $(seq 1 100); do [ -S "$SOCK" ] && break; sleep 0.05; done
args=(render "$S" --remote="$SOCK" --method "$M" --width 1280 --height 720 --frames 45 --quiet
      --set output.compression="\"$COMP\"")
for c in $CLIENTS; do "$B/$c" "${args[@]}" --output "$D/warm.exr" || exit 1; done
for run in $(seq 1 "$RUNS"); do
  for c in $CLIENTS; do
    out=r.exr; [ -n "${FRESH:-}" ] && out=r_${c}_$run.exr
    t0=$(date +%s.%N)
    "$B/$c" "${args[@]}" --set camera.position="[2.9$run,-2.38,1.6882]" --output "$D/$out" || exit 1
    t1=$(date +%s.%N)
    r=$(oiiotool --info -v "$D/$out" | sed -n 's/.*vsd\/render_seconds: "\([0-9.]*\)".*/\1/p')
    echo "$c $(echo "$t1 - $t0 - $r" | bc)"
  done
done > "$D/over.txt"
mode="one file replaced"; [ -n "${FRESH:-}" ] && mode="a new file per request"
echo "method $M, compression $COMP, $RUNS runs, $mode"
sort -k1,1 -k2n "$D/over.txt" | awk '{ v[$1] = v[$1] sprintf(" %.3f", $2); n[$1]++; s[$1, n[$1]] = $2 }
  END { for (k in v) printf "%-9s median %.3f s over the render; all:%s\n", k, s[k, int((n[k] + 1) / 2)], v[k] }'
