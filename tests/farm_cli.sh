#!/usr/bin/env bash
# `vsd farm` without a cluster: the printed job-array script (options forwarded, farm options
# not, safe quoting), one array task run by hand renders exactly its chunk, `vsd farm status`
# sorts frames into done / missing / failed, --submit hands the script to sbatch (a stand-in
# on PATH here; tests/farm_slurm.sh uses a real cluster), and bad command lines fail with a
# message naming the problem.
# Usage: farm_cli.sh VSD SOURCE_DIR SHARED_DATA_DIR TMP_DIR
set -u
vsd=$(readlink -f "$1") src=$2 tmp=$4/farm_cli
scene=$(readlink -f "$3")/scenes/smoke64_sunset.json
rm -rf "$tmp" && mkdir -p "$tmp/bin" && cd "$tmp" || exit 1
fail=0
check() { if ! eval "$2"; then echo "FAIL: $1" >&2; fail=1; fi; }
[ -r "$scene" ] || { echo "FAIL: no test data: $scene" >&2; exit 1; }

# A tiny sequence: frames 1-7 in chunks of 3 -> tasks 0 (1-3), 1 (4-6), 2 (7). The output
# path has a space and a quote, which the script must pass through to vsd unharmed.
out="o'k dir/f_####.exr"
job=("$scene" --frames 1-7 --width 32 --height 18 --samples 2 --output "$out")
exr() { printf "%s/o'k dir/f_%04d.exr" "$tmp" "$1"; }

# A stand-in sbatch that records what it was given; it must not be called without --submit.
cat > bin/sbatch <<'EOF'
#!/bin/sh
echo "$@" >> "$(dirname "$0")/sbatch.calls"
cp "$1" "$(dirname "$0")/submitted.sh"
echo "Submitted batch job 42"
EOF
chmod +x bin/sbatch

# 1. The script on stdout.
PATH=$tmp/bin:$PATH "$vsd" farm slurm "${job[@]}" --chunk 3 --partition debug --cpus 1 \
  --sbatch --time=5 > job.sh 2>err; rc=$?
check "script printed (rc $rc: $(cat err))" '[ $rc -eq 0 ] && [ -s job.sh ]'
check "nothing submitted without --submit" '[ ! -e bin/sbatch.calls ]'
check "valid sh" 'sh -n job.sh'
check "array of 3 tasks, 0-based" 'grep -qx "#SBATCH --array=0-2" job.sh'
check "partition" 'grep -qx "#SBATCH --partition=debug" job.sh'
check "cpus per task" 'grep -qx "#SBATCH --cpus-per-task=1" job.sh'
check "extra #SBATCH line" 'grep -qx "#SBATCH --time=5" job.sh'
check "per-task log in vsd-farm/" 'grep -qx "#SBATCH --output=$tmp/vsd-farm/vsd-smoke64_sunset-%a.log" job.sh'
check "log folder created" '[ -d vsd-farm ]'
check "runs in the submission folder" 'grep -qx "cd '"'$tmp'"' || exit 1" job.sh'
exec_line=$(grep "^exec " job.sh)
check "absolute path of this vsd" '[[ "$exec_line" == "exec '"'$vsd'"' render --threads 1 "* ]]'
check "render options forwarded" '[[ "$exec_line" == *"'"'--samples' '2'"'"* ]]'
check "chunk and --continue added" '[[ "$exec_line" == *"--frames \"\$a-\$b\" --continue" ]]'
check "farm options not forwarded" '! grep -E -- "^exec .*(--chunk|--partition|--submit|--cpus|--sbatch|1-7)" job.sh'

# An INI job with a [Section]: its own name (and logs), its frames from the INI file.
"$vsd" farm slurm "$src/examples/pipeline/farm/smoke64-farm.ini[Final]" --chunk 4 > ini.sh 2>err; rc=$?
check "INI job (rc $rc: $(cat err))" '[ $rc -eq 0 ]'
check "INI job named after file and section" 'grep -qx "#SBATCH --job-name=vsd-smoke64-farm-Final" ini.sh'
check "INI job: Initial_Frame..Final_Frame 1-30 in 8 tasks" 'grep -qx "#SBATCH --array=0-7" ini.sh && grep -q "^first=1 last=30 chunk=4 tasks=8$" ini.sh'

# 2. One task by hand renders exactly its chunk.
SLURM_ARRAY_TASK_ID=2 sh job.sh > task2.log 2>&1; rc=$?
check "task 2 by hand (rc $rc: $(tail -n 3 task2.log))" '[ $rc -eq 0 ]'
check "task 2 wrote frame 7 only" '[ "$(ls "o'"'"'k dir")" = "f_0007.exr" ]'
SLURM_ARRAY_TASK_ID=1 sh job.sh > task1.log 2>&1; rc=$?
check "task 1 by hand (rc $rc)" '[ $rc -eq 0 ]'
check "task 1 wrote frames 4-6" '[ "$(ls "o'"'"'k dir" | tr "\n" " ")" = "f_0004.exr f_0005.exr f_0006.exr f_0007.exr " ]'
check "task 1 log names its chunk" 'grep -q "task 1: frames 4-6" task1.log'
SLURM_ARRAY_TASK_ID=3 sh job.sh > bad.log 2>&1; rc=$?
check "task past the end exits 2 (got $rc)" '[ $rc -eq 2 ] && grep -q "past the last array task 2" bad.log'
env -u SLURM_ARRAY_TASK_ID sh job.sh > bad.log 2>&1; rc=$?
check "no task id exits 2 (got $rc)" '[ $rc -eq 2 ] && grep -q "SLURM_ARRAY_TASK_ID must be an array task 0..2" bad.log'

# 3. Status: 4-7 done, 1-3 missing (task 0).
"$vsd" farm status "${job[@]}" --chunk 3 > st 2>err; rc=$?
check "status exits 1 while frames are missing (got $rc: $(cat err))" '[ $rc -eq 1 ]'
check "status: done" 'grep -Eq "^done +4  4-7$" st'
check "status: missing, with the task" 'grep -Eq "^missing +3  1-3  \(array task 0\)$" st'
check "status: none failed" 'grep -Eq "^failed +0$" st'
# Now break some: 5 truncated, 6 rendered from another scene, 2 killed while writing.
head -c 2000 "$(exr 5)" > t && mv t "$(exr 5)"
"$vsd" render "$scene" --frames 6 --width 32 --height 18 --samples 3 --output "$out" --quiet
echo partial > "$(exr 2).tmp-12345"
"$vsd" farm status "${job[@]}" --chunk 3 > st 2>err; rc=$?
check "status exits 1 with failures (got $rc)" '[ $rc -eq 1 ]'
check "status: done 4,7" 'grep -Eq "^done +2  4,7$" st'
check "status: missing 1,3" 'grep -Eq "^missing +2  1,3  \(array task 0\)$" st'
check "status: failed 2,5-6" 'grep -Eq "^failed +3  2,5-6  \(array tasks 0-1\)$" st'
check "status: why 2 failed" 'grep -q "^frame 2: failed: .*f_0002.exr.tmp-12345" st'
check "status: why 6 failed" 'grep -q "^frame 6: failed: .*another scene" st'
check "status: why 5 failed" 'grep -q "^frame 5: failed: " st'

# 4. Running every task again renders what is not done, and only that.
before=$(stat -c '%i %y' "$(exr 4)" "$(exr 7)")
for t in 0 1 2; do SLURM_ARRAY_TASK_ID=$t sh job.sh; done > rerun.log 2>&1
check "done frames untouched" '[ "$(stat -c "%i %y" "$(exr 4)" "$(exr 7)")" = "$before" ]'
rendered=$(grep -Eo "^frame [0-9]+: /.*\.exr +\(" rerun.log | cut -d: -f1 | tr "\n" " ")
check "re-run rendered 1,2,3,5,6 (got '$rendered')" '[ "$rendered" = "frame 1 frame 2 frame 3 frame 5 frame 6 " ]'
"$vsd" farm status "${job[@]}" --chunk 3 > st 2>err; rc=$?
check "status exits 0 when all done (got $rc)" '[ $rc -eq 0 ] && grep -Eq "^done +7  1-7$" st'

# 5. --submit: the same script, written beside the logs and passed to sbatch.
PATH=$tmp/bin:$PATH "$vsd" farm slurm "${job[@]}" --chunk 3 --partition debug --cpus 1 --sbatch --time=5 \
  --submit > sub.out 2>sub.err; rc=$?
check "--submit (rc $rc: $(cat sub.err))" '[ $rc -eq 0 ]'
check "sbatch's output passed on" 'grep -qx "Submitted batch job 42" sub.out'
check "sbatch got the script file" '[ "$(cat bin/sbatch.calls)" = "$tmp/vsd-farm/vsd-smoke64_sunset.sbatch" ]'
check "submitted script = printed script" 'cmp -s bin/submitted.sh job.sh'

# 6. Errors: exit 2 (bad command line) or 1 (sbatch), with a message naming the problem.
expect() { # expect RC PATTERN ARGS...: vsd exits RC and says PATTERN on stderr
  local want=$1 pat=$2; shift 2
  "$vsd" "$@" > /dev/null 2> err; local rc=$?
  check "vsd $* -> $want (got $rc)" '[ $rc -eq $want ]'
  check "vsd $* says '$pat' (said: $(cat err))" 'grep -q -- "$pat" err'
}
expect 2 "--chunk: expected a whole number of frames >= 1, got '0'" farm slurm "${job[@]}" --chunk 0
expect 2 "--chunk: expected a whole number of frames >= 1, got 'ten'" farm slurm "${job[@]}" --chunk ten
expect 2 "--chunk N is needed" farm slurm "${job[@]}"
expect 2 "--chunk needs a value" farm slurm "${job[@]}" --chunk
expect 2 "--frames: '7-1': end 1 before start 7" farm slurm "$scene" --frames 7-1 --chunk 2
expect 2 "--frames: expected A-B or N, got 'all'" farm status "$scene" --frames all
expect 2 "unknown option '--bogus'" farm slurm "${job[@]}" --chunk 2 --bogus 1
expect 2 "unknown farm command 'pbs'" farm pbs "$scene"
expect 2 "no scene file or INI file" farm slurm --chunk 3
expect 2 "has no #### for the frame number" farm slurm "$scene" --frames 1-3 --chunk 1 --output one.exr
expect 2 "log folder '$tmp/my logs' has a space" farm slurm "${job[@]}" --chunk 3 --log-dir "my logs"
expect 3 "missing.json" farm slurm "$tmp/missing.json" --chunk 3
PATH=$tmp/nobin "$vsd" farm slurm "${job[@]}" --chunk 3 --submit > /dev/null 2> err; rc=$?
check "no sbatch -> 1 (got $rc)" '[ $rc -eq 1 ] && grep -q "cannot run sbatch: No such file or directory (is Slurm installed" err'
printf '#!/bin/sh\necho "sbatch: error: invalid partition specified: nope" >&2\nexit 1\n' > bin/sbatch
PATH=$tmp/bin:$PATH "$vsd" farm slurm "${job[@]}" --chunk 3 --partition nope --submit > /dev/null 2> err; rc=$?
check "failing sbatch -> 1 (got $rc)" '[ $rc -eq 1 ]'
check "sbatch's error passed on" 'grep -q "sbatch: error: invalid partition specified: nope" err'
check "failure named" 'grep -q "sbatch failed with exit status 1" err'

exit $fail
