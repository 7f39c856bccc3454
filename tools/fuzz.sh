#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, build/fuzz) and runs each for a bounded time.
#   tools/fuzz.sh [SECONDS_PER_TARGET]   (default 30; CI runs it from tools/bootstrap.sh test)
# A crash, a leak or a sanitizer report fails the run and leaves the input in build/fuzz/crashes/.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH=${1:-30}
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$(nproc 2>/dev/null || echo 2)" >/dev/null
mkdir -p build/fuzz/crashes
status=0
for target in build/fuzz/bin/*_fuzz; do
  name=$(basename "$target")
  corpus=build/fuzz/corpus/$name
  mkdir -p "$corpus"
  echo "    fuzzing $name for ${SECONDS_EACH} s"
  seeds=()  # small hand-written inputs, read but never written (tests/fuzz/seeds/<target>)
  if [ -d tests/fuzz/seeds/"$name" ]; then seeds=(tests/fuzz/seeds/"$name"); fi
  if ! "$target" "$corpus" "${seeds[@]}" -max_total_time="$SECONDS_EACH" -rss_limit_mb=2048 \
      -artifact_prefix=build/fuzz/crashes/"$name"- -print_final_stats=1 \
      > build/fuzz/"$name".log 2>&1; then
    echo "FUZZ FAILED: $name (build/fuzz/$name.log, inputs in build/fuzz/crashes/)"
    tail -n 30 build/fuzz/"$name".log
    status=1
  else
    runs=$(grep -m1 '^stat::number_of_executed_units' build/fuzz/"$name".log | awk '{print $2}')
    echo "    $name: ${runs:-?} inputs, no failure"
  fi
done
exit $status
