#!/usr/bin/env bash
# `vsd farm slurm --submit` on a real Slurm cluster: a 12-frame sequence in 4 array tasks;
# one task is cancelled in the middle of a frame; the same command submitted again renders
# only what that task left; every frame is rendered exactly once after the kill, and all 12
# equal an in-process `vsd render` of the same frames.
# Uses the cluster `sinfo` answers (e.g. SLURM_CONF from .ci/run), else starts a one-node
# cluster with scripts/slurm-local.sh and stops it on exit. Exit 77 (skip) only when Slurm
# is not installed, or no cluster answers and this user cannot start one (not root).
# Usage: farm_slurm.sh VSD SOURCE_DIR SHARED_DATA_DIR TMP_DIR
set -u
vsd=$(readlink -f "$1") src=$(readlink -f "$2") tmp=$4/farm_slurm
scene=$(readlink -f "$3")/scenes/smoke64_sunset.json
fail=0
check() { if ! eval "$2"; then echo "FAIL: $1" >&2; fail=1; fi; }
say() { echo "[$(date +%T)] $*"; }

for b in sbatch squeue scancel sinfo; do
  command -v "$b" > /dev/null || { echo "SKIP: $b not found (Debian packages slurm-wlm, munge)"; exit 77; }
done
[ -r "$scene" ] || { echo "FAIL: no test data: $scene" >&2; exit 1; }
rm -rf "$tmp" && mkdir -p "$tmp/work" || exit 1

if timeout 20 sinfo -h > /dev/null 2>&1; then
  say "using the running cluster: $(sinfo -h -o '%P %D nodes %T' | head -n 1)"
else
  if [ "$(id -u)" -ne 0 ] || ! command -v slurmctld > /dev/null || ! command -v munged > /dev/null; then
    echo "SKIP: no Slurm cluster answers and this user cannot start one (needs root, slurmctld, munged)"
    exit 77
  fi
  state=$tmp/slurm
  trap '"$src/scripts/slurm-local.sh" stop "$state"' EXIT
  "$src/scripts/slurm-local.sh" start "$state" || { echo "FAIL: could not start a local cluster" >&2; exit 1; }
  export SLURM_CONF=$state/slurm.conf
fi
cd "$tmp/work" || exit 1

# Frames take about two seconds on one CPU, long enough to be caught in the middle.
opts=(--width 64 --height 36 --samples 1536 --output out/f_####.exr)
farm=("$scene" --frames 1-12 --chunk 3 --cpus 1 "${opts[@]}" --submit)
exr() { printf "out/f_%04d.exr" "$1"; }
log() { echo "vsd-farm/vsd-smoke64_sunset-$1.log"; }

# Waits (at most $2 s) until job $1 has left the queue.
drain() {
  local i
  for i in $(seq $(($2 * 5))); do
    [ -z "$(squeue -h -j "$1" -o %i 2>/dev/null)" ] && return 0
    sleep 0.2
  done
  echo "FAIL: job $1 still queued after $2 s: $(squeue -j "$1" 2>&1)" >&2
  return 1
}

# 1. Submit; cancel task 2 (frames 7-9) once frame 7 is written and frame 8 is under way.
say "submit"
"$vsd" farm slurm "${farm[@]}" > sub.out 2> sub.err; rc=$?
job=$(sed -n 's/^Submitted batch job \([0-9]*\).*/\1/p' sub.out)
check "submitted (rc $rc: $(cat sub.out sub.err))" '[ $rc -eq 0 ] && [ -n "$job" ]'
[ -n "$job" ] || exit 1
caught=0
for i in $(seq 1800); do
  # A task renders its frames in order: with 7 written (renamed into place) and 8 not yet,
  # frame 8 is being rendered.
  if [ -s "$(exr 7)" ] && [ ! -e "$(exr 8)" ]; then
    scancel "${job}_2" && caught=1
    break
  fi
  [ -z "$(squeue -h -j "$job" -o %i 2>/dev/null)" ] && break
  sleep 0.1
done
check "task 2 cancelled while rendering frame 8" '[ $caught -eq 1 ]'
say "cancelled ${job}_2"
drain "$job" 180 || fail=1
check "frame 8 never written (killed mid-frame)" '[ ! -e "$(exr 8)" ]'
check "frame 9 never started" '[ ! -e "$(exr 9)" ] && ! grep -q "^frame 9" "$(log 2)"'
"$vsd" farm status "${farm[@]}" > st 2>&1; rc=$?
check "status after the kill: 10 done, 8-9 missing in task 2 (rc $rc: $(cat st))" \
  '[ $rc -eq 1 ] && grep -Eq "^done +10  1-7,10-12$" st && grep -Eq "^missing +2  8-9  \(array task 2\)$" st'
# Identity and time of every frame there: a frame rendered again would change both.
before=$(for f in 1 2 3 4 5 6 7 10 11 12; do stat -c "%n %i %y" "$(exr $f)"; done)

# 2. The same command again: only task 2's two missing frames render.
say "submit again"
"$vsd" farm slurm "${farm[@]}" > sub.out 2> sub.err; rc=$?
job2=$(sed -n 's/^Submitted batch job \([0-9]*\).*/\1/p' sub.out)
check "submitted again (rc $rc: $(cat sub.out sub.err))" '[ $rc -eq 0 ] && [ -n "$job2" ]'
[ -n "$job2" ] && { drain "$job2" 180 || fail=1; }
say "done"
for f in $(seq 12); do check "frame $f written" '[ -s "$(exr $f)" ]'; done
after=$(for f in 1 2 3 4 5 6 7 10 11 12; do stat -c "%n %i %y" "$(exr $f)"; done)
check "frames done before the kill were not written again" '[ "$after" = "$before" ]'
# Every "frame N: <path> (...)" line is one rendered frame; over both submissions, each
# frame has exactly one (frame 8's first attempt died before its line).
cat vsd-farm/vsd-smoke64_sunset-*.log > all.log
for f in $(seq 12); do
  n=$(grep -Ec "^frame $f: /.*f_$(printf %04d $f)\.exr +\(" all.log)
  check "frame $f rendered once (rendered $n times)" '[ "$n" -eq 1 ]'
done
check "task 2's second attempt skipped frame 7" 'grep -q "^frame 7: skipped, complete" "$(log 2)"'
for t in 0 1 3; do
  check "task $t's second attempt skipped all 3 frames" \
    'grep -q "^--continue: 3 of 3 frames complete and skipped; 0 to render" "$(log $t)"'
done
"$vsd" farm status "${farm[@]}" > st 2>&1; rc=$?
check "status at the end: all 12 done (rc $rc: $(cat st))" '[ $rc -eq 0 ] && grep -Eq "^done +12  1-12$" st'

# 3. The same frames in-process, all threads, one run: the same pixels.
say "in-process render"
"$vsd" render "$scene" --frames 1-12 "${opts[@]/out\/f_/ref/f_}" --quiet; rc=$?
check "in-process render (rc $rc)" '[ $rc -eq 0 ]'
for f in $(seq 12); do
  a=$(exr $f) b=ref/${a#out/}
  if command -v idiff > /dev/null; then
    check "frame $f equals the in-process render" 'idiff -a -fail 0 -warn 0 "$a" "$b" > /dev/null'
  else
    check "frame $f equals the in-process render" \
      '! "$vsd" compare "$a" "$b" | grep -v "is black" | grep -qv "rel. RMSE 0.0000$"'
  fi
done
say "checked"
exit $fail
