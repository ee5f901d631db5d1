#!/bin/sh
# Bernabei et al. 2012, Table I on our data: the lighting (marching and diffusion to
# convergence) against the ray history k, the steps each ray advances per round while the
# lattice diffuses 8 steps on what the rays have left (k = 0: march everything, then
# diffuse). A 128^3 volume (smoke128 frame 45) at 1024x1024, as in the paper.
# usage: bench/lbl/table1.sh BUILD_DIR [KS] [EXTRA --set ARGS...]
set -eu
build=${1:?usage: table1.sh BUILD_DIR [KS] [--set ...]}
ks=${2:-"0 2 4 8 16 32 64 128"}
shift; [ $# -gt 0 ] && shift
here=$(cd "$(dirname "$0")/../.." && pwd)
scene="$here/../shared/data/scenes/smoke128_forest.json"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| k | rounds | lattice steps (during the march) | march s (with the lattice's steps meanwhile) | diffusion after s | lighting s | frame s (1024x1024) |"
echo "|---|---|---|---|---|---|---|"
for k in $ks; do
    start=$(date +%s.%N)
    log=$("$build/vsd" render "$scene" --method lbl --frames 45 --width 1024 --height 1024 --cache-dir none \
          --set "render.options.history=$k" "$@" --output "$out/f.exr" 2>&1)
    end=$(date +%s.%N)
    info=$(printf '%s\n' "$log" | grep 'lbl:')
    val() { printf '%s\n' "$info" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
    m=$(val march_seconds); d=$(val diffusion_seconds)
    echo "| $k | $(val history_rounds) | $(val diffusion_steps) ($(val history_steps)) | $m | $d | $(awk "BEGIN { print $m + $d }") | $(awk "BEGIN { printf \"%.2f\", $end - $start }") |"
done
