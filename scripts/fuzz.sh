#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz (clang, ASan + UBSan, -DVSD_FUZZ=ON) and runs
# each for a while, starting from the committed corpus. Reports per harness: executions,
# exec/s, coverage (libFuzzer's cov = edges, ft = features), corpus size, and crash / leak /
# timeout / OOM artifacts; exits non-zero when any harness found something.
#
# Usage: scripts/fuzz.sh [TOTAL_SECONDS]          split evenly across the harnesses (default 60)
#        scripts/fuzz.sh --per-harness SECONDS    each harness this long
#   --only a,b         just these harnesses (protocol, scene, vdb, env, daemon)
#   --work DIR         corpora grown by this run, artifacts, logs (default build-fuzz/fuzz-work)
#   --build-dir DIR    the clang build (default build-fuzz)
#   --no-build         use the harnesses already built
#   --jobs N           build parallelism (default 2)
#   -- ARGS...         extra libFuzzer flags for every harness
# New inputs go to WORK/corpus/<name>, never into tests/fuzz/corpus (minimise and commit by
# hand: tests/fuzz/README.md). Reproduce a finding: build-fuzz/tests/fuzz_<name> ARTIFACT.
set -euo pipefail
cd "$(dirname "$0")/.."

total=60
per=""
only=""
build=build-fuzz
work=""
do_build=1
jobs=2
extra=()
all=(protocol scene vdb env daemon)

while [ $# -gt 0 ]; do
  case "$1" in
    --per-harness) per=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --build-dir) build=$2; shift 2 ;;
    --no-build) do_build=0; shift ;;
    --jobs) jobs=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    -h|--help) sed -n '2,19p' "$0"; exit 0 ;;
    [0-9]*) total=$1; shift ;;
    *) echo "fuzz.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
work=${work:-$build/fuzz-work}

harnesses=()
if [ -n "$only" ]; then
  IFS=, read -r -a harnesses <<< "$only"
else
  harnesses=("${all[@]}")
fi
if [ -z "$per" ]; then
  per=$(( total / ${#harnesses[@]} ))
  [ "$per" -ge 1 ] || per=1
fi

if [ "$do_build" -eq 1 ]; then
  if [ ! -f "$build/CMakeCache.txt" ]; then
    cmake -S . -B "$build" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
      -DVSD_FUZZ=ON -DVSD_SANITIZE=ON -DVSD_CUDA=OFF -DVSD_BLENDER_TESTS=OFF \
      -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
  fi
  cmake --build "$build" -j"$jobs" --target fuzz_all
fi

# Leaks and UB are findings; halt at the first report so libFuzzer saves the input.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# leaks inside third-party libraries that vsd cannot fix (each one explained in the file)
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0}

status=0
summary=$work/summary.tsv
mkdir -p "$work"
printf 'harness\tseconds\texecs\texec_per_s\tcov\tft\tcorpus\tnew\tpeak_rss_mb\tresult\n' > "$summary"
for name in "${harnesses[@]}"; do
  bin=$build/tests/fuzz_$name
  seeds=tests/fuzz/corpus/$name
  if [ ! -x "$bin" ] || [ ! -d "$seeds" ]; then
    echo "fuzz.sh: no harness '$name' ($bin, $seeds)" >&2
    status=1
    continue
  fi
  mkdir -p "$work/corpus/$name" "$work/artifacts/$name"
  dict=()
  [ -f "tests/fuzz/$name.dict" ] && dict=(-dict="tests/fuzz/$name.dict")
  # the daemon harness runs small renders (jobs are capped at 2 s by the harness)
  timeout=10
  [ "$name" = daemon ] && timeout=30
  log=$work/$name.log
  echo "== fuzz_$name: ${per}s"
  start=$(date +%s)
  set +e
  "$bin" -max_total_time="$per" -timeout="$timeout" -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$work/artifacts/$name/" "${dict[@]}" "${extra[@]}" \
    "$work/corpus/$name" "$seeds" > "$log" 2>&1
  rc=$?
  set -e
  secs=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -1)
  newu=$(sed -n 's/^stat::new_units_added: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  corp=$(grep -o 'corp: [0-9]*/[0-9]*[a-zA-Z]*' "$log" | tail -1 | cut -d' ' -f2)
  found=$(find "$work/artifacts/$name" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
          -o -name 'oom-*' \) | wc -l)
  result=ok
  if [ "$rc" -ne 0 ] || [ "$found" -gt 0 ]; then
    result="FAILED (exit $rc, $found artifacts in $work/artifacts/$name; log $log)"
    status=1
    grep -m5 -E 'ERROR: |runtime error|SUMMARY' "$log" || true
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$secs" "${execs:-0}" "${rate:-0}" "${cov:-?}" \
    "${ft:-?}" "${corp:-?}" "${newu:-0}" "${rss:-?}" "$result" >> "$summary"
done
echo
column -t -s "$(printf '\t')" "$summary" 2>/dev/null || cat "$summary"
exit $status
