#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the libFuzzer targets (clang, build/fuzz) and runs each for a bounded time, as many at
# once as there are cores (each fuzzer is one process on one core), the longest first.
#   tools/fuzz.sh                        FUZZ_CHANGED_SECONDS (default 60) for each target whose
#                                        code changed against a base, FUZZ_SECONDS (default 10)
#                                        for the others, FUZZ_BUDGET (default 100) seconds in all
#                                        at most (tools/fuzz_plan.py says how it chooses;
#                                        FUZZ_BASE=<commit> to choose the base)
#   tools/fuzz.sh SECONDS_PER_TARGET     every target that long
# CI runs it from tools/bootstrap.sh test (docs/testing.md).
# A crash, a leak or a sanitizer report fails the run and leaves the input in build/fuzz/crashes/.
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS=$(nproc 2>/dev/null || echo 2)
cmake --preset fuzz >/dev/null
# The build's output is kept, and its end shown when it fails (a target that no longer compiles).
if ! cmake --build --preset fuzz -j "$JOBS" > build/fuzz/build.log 2>&1; then
  grep -E "error|FAILED" build/fuzz/build.log | head -20
  echo "the fuzz targets do not build: build/fuzz/build.log"
  exit 1
fi
mkdir -p build/fuzz/crashes

if [ $# -gt 0 ]; then
  plan=$(for t in build/fuzz/bin/*_fuzz; do echo "$1 $(basename "$t") all alike"; done)
else
  plan=$(python3 tools/fuzz_plan.py build/fuzz "${FUZZ_SECONDS:-10}" "${FUZZ_CHANGED_SECONDS:-60}" \
         "${FUZZ_BUDGET:-100}" "$JOBS")
fi

# Runs one target; its exit status says whether it found a failure.
fuzz_one() {
  local name=$1 seconds=$2 corpus seeds=()
  corpus=build/fuzz/corpus/$name
  mkdir -p "$corpus"
  # Small hand-written inputs, read but never written (tests/fuzz/seeds/<target>).
  if [ -d tests/fuzz/seeds/"$name" ]; then seeds=(tests/fuzz/seeds/"$name"); fi
  build/fuzz/bin/"$name" "$corpus" "${seeds[@]}" -max_total_time="$seconds" -rss_limit_mb=2048 \
    -artifact_prefix=build/fuzz/crashes/"$name"- -print_final_stats=1 \
    > build/fuzz/"$name".log 2>&1
}

status=0
declare -A running=()  # pid -> target
# Waits for one fuzzer to end and reports it.
reap() {
  local pid rc=0 name
  wait -n -p pid "${!running[@]}" || rc=$?
  name=${running[$pid]}
  unset "running[$pid]"
  if [ "$rc" -ne 0 ]; then
    echo "FUZZ FAILED: $name (build/fuzz/$name.log, inputs in build/fuzz/crashes/)"
    tail -n 30 build/fuzz/"$name".log
    status=1
  else
    runs=$(grep -m1 '^stat::number_of_executed_units' build/fuzz/"$name".log | awk '{print $2}')
    echo "    $name: ${runs:-?} inputs, no failure"
  fi
}

while read -r seconds name why; do
  while ((${#running[@]} >= JOBS)); do reap; done
  echo "    fuzzing $name for $seconds s ($why)"
  fuzz_one "$name" "$seconds" &
  running[$!]=$name
done <<< "$plan"
while ((${#running[@]} > 0)); do reap; done
exit $status
