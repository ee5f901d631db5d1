#!/usr/bin/env bash
# The paper's Table 2 on our data, for method `crm` (issue 13), from the method's own
# figures (vsd render prints them as "crm: key=value ..."; the EXR keeps them as
# vsd/method_info). Per scene: frame 1 of the run is fitted from scratch, frame 2 (where
# the scene is a sequence) starts from frame 1's RBFs (temporal coherence); the cache
# folder is fresh, so every fit is computed. Then a camera-only and a lighting-only
# re-render of the last frame through `vsd render` would reload the files, so those times
# come from bench_tte (docs/tte.md); here: RBFs, fit error, fit / hash / lighting / view
# times and the hash size.
# Usage: bench/crm/table2.sh BUILD_DIR [WIDTHxHEIGHT] > table.md     (default 1280x720)
set -euo pipefail
build=${1:?usage: table2.sh BUILD_DIR [WxH]}
size=${2:-1280x720}
w=${size%x*}; h=${size#*x}
here=$(cd "$(dirname "$0")/../.." && pwd)
data=${VSD_SHARED_DATA:-$here/../shared/data}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "crm, ${w}x${h}, $(nproc) threads, $(date -u +%F), $(uname -m), vsd $("$build/vsd" version 2>/dev/null | head -1)"
echo
echo "| scene | frame | RBFs | fit rel. error | fit s | fit evaluations | hash stored | hash KiB | hash s | single s | orders s | prepare s | view s |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
# scene:first-frame:second-frame (second empty for single-file scenes)
for spec in smoke64_sunset:24:27 smoke128_forest:45: cloud128_interior:: cloud256_sunset:: fire96_studio:48:; do
  IFS=: read -r scene f1 f2 <<<"$spec"
  frames=${f1:+$f1}${f2:+-$f2}
  args=(render "$data/scenes/$scene.json" --method crm --width "$w" --height "$h" --cache-dir "$out/cache-$scene"
        --output "$out/$scene-####.exr")
  [ -n "$frames" ] && args+=(--frames "$frames")
  "$build/vsd" "${args[@]}" 2>/dev/null | awk -v scene="$scene" '
    /^frame [0-9]+:/ { frame = $2; sub(":", "", frame)
                       match($0, /prepare [0-9.]+s/); prep = substr($0, RSTART + 8, RLENGTH - 9)
                       match($0, /render [0-9.]+s/); view = substr($0, RSTART + 7, RLENGTH - 8) }
    /^  crm:/ { for (i = 2; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] }
                printf "| %s | %s | %s | %.4f | %s | %s | %s | %.0f | %s | %s | %s | %s | %s |\n", scene, frame,
                       v["rbfs"], v["fit_rel_error"], v["fit_seconds"], v["fit_evaluations"], v["hash_stored"],
                       v["hash_bytes"] / 1024, v["hash_seconds"], v["single_seconds"], v["orders_seconds"], prep, view }'
done
