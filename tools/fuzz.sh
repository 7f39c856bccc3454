#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the libFuzzer targets (clang, build/fuzz) and runs each for a bounded time, as many at
# once as there are cores (each fuzzer is one process on one core).
#   tools/fuzz.sh [SECONDS_PER_TARGET]   (default 30; CI runs it from tools/bootstrap.sh test)
# A crash, a leak or a sanitizer report fails the run and leaves the input in build/fuzz/crashes/.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH=${1:-30}
JOBS=$(nproc 2>/dev/null || echo 2)
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$JOBS" >/dev/null
mkdir -p build/fuzz/crashes

# Runs one target; its exit status says whether it found a failure.
fuzz_one() {
  local target=$1 name corpus seeds=()
  name=$(basename "$target")
  corpus=build/fuzz/corpus/$name
  mkdir -p "$corpus"
  # Small hand-written inputs, read but never written (tests/fuzz/seeds/<target>).
  if [ -d tests/fuzz/seeds/"$name" ]; then seeds=(tests/fuzz/seeds/"$name"); fi
  "$target" "$corpus" "${seeds[@]}" -max_total_time="$SECONDS_EACH" -rss_limit_mb=2048 \
    -artifact_prefix=build/fuzz/crashes/"$name"- -print_final_stats=1 \
    > build/fuzz/"$name".log 2>&1
}

status=0
targets=(build/fuzz/bin/*_fuzz)
for ((i = 0; i < ${#targets[@]}; i += JOBS)); do
  batch=("${targets[@]:i:JOBS}")
  pids=()
  for target in "${batch[@]}"; do
    echo "    fuzzing $(basename "$target") for ${SECONDS_EACH} s"
    fuzz_one "$target" &
    pids+=($!)
  done
  for j in "${!batch[@]}"; do
    name=$(basename "${batch[$j]}")
    if ! wait "${pids[$j]}"; then
      echo "FUZZ FAILED: $name (build/fuzz/$name.log, inputs in build/fuzz/crashes/)"
      tail -n 30 build/fuzz/"$name".log
      status=1
    else
      runs=$(grep -m1 '^stat::number_of_executed_units' build/fuzz/"$name".log | awk '{print $2}')
      echo "    $name: ${runs:-?} inputs, no failure"
    fi
  done
done
exit $status
