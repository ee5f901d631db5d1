#!/bin/sh
# Bernabei et al. 2012, Fig. 11 on our data: lattice steps to convergence and lighting time
# against the albedo, on a 128^3 volume (smoke128 frame 45) at 1024x1024.
# usage: bench/lbl/fig11.sh BUILD_DIR [ALBEDOS]
set -eu
build=${1:?usage: fig11.sh BUILD_DIR [ALBEDOS]}
albedos=${2:-"0.5 0.7 0.85 0.95 0.99"}
here=$(cd "$(dirname "$0")/../.." && pwd)
scene="$here/../shared/data/scenes/smoke128_forest.json"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| albedo | lattice steps | converged | march s | diffusion s | view s (1024x1024) |"
echo "|---|---|---|---|---|---|"
for a in $albedos; do
    log=$("$build/vsd" render "$scene" --method lbl --frames 45 --width 1024 --height 1024 \
          --set "medium.albedo=[$a,$a,$a]" --output "$out/f.exr" 2>&1)
    info=$(printf '%s\n' "$log" | grep 'lbl:')
    view=$(printf '%s\n' "$log" | sed -n 's/.*render \([0-9.]*\)s.*/\1/p')
    val() { printf '%s\n' "$info" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
    echo "| $a | $(val diffusion_steps) | $(val diffusion_converged) | $(val march_seconds) | $(val diffusion_seconds) | $view |"
done
