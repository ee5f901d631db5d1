#!/bin/sh
# Bernabei et al. 2012, Fig. 11 on our data: lattice steps to convergence and lighting time
# against the albedo, on a 128^3 volume (smoke128 frame 45) at 1024x1024.
# usage: bench/lbl/fig11.sh BUILD_DIR [ALBEDOS]
set -eu
build=${1:?usage: fig11.sh BUILD_DIR [ALBEDOS]}
albedos=${2:-"0.5 0.7 0.85 0.95 0.99"}
. "$(dirname "$0")/common.sh"
echo "| albedo | lattice steps | converged | march s | diffusion s | view s (1024x1024) |"
echo "|---|---|---|---|---|---|"
for a in $albedos; do
    lbl_run --set "medium.albedo=[$a,$a,$a]"
    view=$(printf '%s\n' "$log" | sed -n 's/.*render \([0-9.]*\)s.*/\1/p')
    echo "| $a | $(val diffusion_steps) | $(val diffusion_converged) | $(val march_seconds) | $(val diffusion_seconds) | $view |"
done
