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
. "$(dirname "$0")/common.sh"
echo "| k | rounds | lattice steps (during the march) | march s (with the lattice's steps meanwhile) | diffusion after s | lighting s | frame s (1024x1024) |"
echo "|---|---|---|---|---|---|---|"
for k in $ks; do
    start=$(date +%s.%N)
    lbl_run --set "render.options.history=$k" "$@"
    end=$(date +%s.%N)
    m=$(val march_seconds); d=$(val diffusion_seconds)
    echo "| $k | $(val history_rounds) | $(val diffusion_steps) ($(val history_steps)) | $m | $d | $(awk "BEGIN { print $m + $d }") | $(awk "BEGIN { printf \"%.2f\", $end - $start }") |"
done
