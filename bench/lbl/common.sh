# Sourced by bench/lbl/*.sh: the scenes of their tables (smoke128 frame 45, a 128^3 volume,
# at 1024x1024, as the paper's Fig. 11 and Table I), run once per row.
#   lbl_run ARGS...  renders it with lbl and ARGS (--set ...); $log holds the CLI's output,
#                    $info the method_info line
#   val KEY          a value of that line
here=$(cd "$(dirname "$0")/../.." && pwd)
scene="$here/../shared/data/scenes/smoke128_forest.json"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
lbl_run() {
    log=$("$build/vsd" render "$scene" --method lbl --frames 45 --width 1024 --height 1024 --cache-dir none \
          "$@" --output "$out/f.exr" 2>&1)
    info=$(printf '%s\n' "$log" | grep 'lbl:')
}
val() { printf '%s\n' "$info" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
