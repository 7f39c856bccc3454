#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The module SDK as a module author uses it: docs/plugins.md, "Your first module in ten minutes",
# run as written. Installs the hub with its SDK into ~/skrobot (step 1, here with this build),
# then runs every ```sh block of that section in order, in one shell, from the checkout, with
# ~ a temporary home. Then checks what the steps promise: only the entry symbol is exported, the
# counts are right, the installed module is listed; and builds the example once more through
# pkg-config.
#   module_sdk_test.sh BUILD_DIR SOURCE_DIR CMAKE CXX [CXX_FLAGS]
# CXX_FLAGS are the build's own (sanitizers must match between the SDK's library and a module).
set -euo pipefail
build=$1 src=$2 cmake=$3 cxx=$4 cxxflags=${5:-}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/skrobot-sdk-XXXXXX")
export HOME=$tmp/home
mkdir -p "$HOME"
cleanup() {
  pkill -f "^$HOME/skrobot/bin/skrobot" 2>/dev/null || true
  rm -rf "$tmp"
}
trap cleanup EXIT
step() { echo "== $*"; }
fail() { echo "FAIL: $*" >&2; exit 1; }

step "1. install the hub and its SDK into ~/skrobot"
"$cmake" --install "$build" --prefix "$HOME/skrobot" > "$tmp/install.log" 2>&1 ||
  { cat "$tmp/install.log"; fail "cmake --install"; }

step "2.. the sh blocks of the section, in order"
section=$(awk '/^## Your first module in ten minutes/{on=1; next} /^## /{on=0} on' \
  "$src/docs/plugins.md")
[[ -n $section ]] || fail "docs/plugins.md has no section 'Your first module in ten minutes'"
# The fenced blocks marked sh, their indentation (inside a list item) removed.
script=$(awk '/^ *```sh$/{on=1; match($0, /^ */); ind=RLENGTH; next}
              /^ *```$/{on=0; next}
              on{print substr($0, ind + 1)}' <<<"$section")
blocks=$(grep -c '^ *```sh$' <<<"$section" || true)
[[ $blocks -ge 5 ]] || fail "expected at least 5 sh blocks, found $blocks"
printf '%s\n' "$script" > "$tmp/tutorial.sh"
# The compiler and flags of this build (a sanitizer build's SDK needs its modules built alike).
export CXX=$cxx CXXFLAGS=$cxxflags
export PATH="$(dirname "$cmake"):$PATH"
(cd "$src" && timeout 300 bash -euo pipefail "$tmp/tutorial.sh") > "$tmp/tutorial.log" 2>&1 ||
  { cat "$tmp/tutorial.log"; fail "the tutorial's steps"; }
cat "$tmp/tutorial.log"

# The symbols a module exports besides the standard library's template instances (libstdc++
# declares namespace std with default visibility) and the linker's own: only the entry symbol.
own_exports() {
  nm -DC --defined-only "$1" | cut -d' ' -f3- |
    grep -Ev '^([^(]* )?(std|__gnu_cxx)::|for (std|__gnu_cxx)::|^(_edata|_end|__bss_start|_init|_fini)$' | sort -u
}

step "what the steps promise"
so=$HOME/primes/build/primes.so
exported=$(own_exports "$so")
[[ $exported == skrobot_module_entry ]] ||
  fail "primes.so exports more than its entry symbol: $exported"
grep -q 'period_ms' "$tmp/tutorial.log" || fail "--describe-module printed no period_ms"
grep -q '{"below":1000,"label":"primes","primes":168}' "$tmp/tutorial.log" ||
  fail "the first count is not 168 primes below 1000"
grep -q '{"below":3000,"label":"primes","primes":430}' "$tmp/tutorial.log" ||
  fail "the third count is not 430 primes below 3000"
moddir=$(dirname "$(find "$HOME/skrobot" -path '*/skrobot/modules/face-detect.so' | head -1)")
[[ -f $moddir/primes.so ]] || fail "cmake --install did not put primes.so into $moddir"
deps=$(ldd "$so")
if grep -q "$build" <<<"$deps"; then fail "primes.so uses the build tree: $deps"; fi

step "pkg-config: the same module with one command line"
pc=$(find "$HOME/skrobot" -name skrobot-module.pc)
[[ -n $pc ]] || fail "no skrobot-module.pc installed"
export PKG_CONFIG_PATH=$(dirname "$pc")
[[ $(pkg-config --variable=moduledir skrobot-module) -ef $moddir ]] ||
  fail "pkg-config's moduledir is not $moddir"
# shellcheck disable=SC2046,SC2086
"$cxx" $cxxflags -shared -Wl,--no-undefined -o "$tmp/primes.so" "$src/examples/out-of-tree-module/src/primes.cpp" \
  $(pkg-config --cflags --libs skrobot-module)
exported=$(own_exports "$tmp/primes.so")
[[ $exported == skrobot_module_entry ]] || fail "the pkg-config build exports: $exported"
"$HOME/skrobot/bin/skrobot" --describe-module "$tmp/primes.so" > "$tmp/describe.log" 2>&1 ||
  { cat "$tmp/describe.log"; fail "--describe-module of the pkg-config build"; }
grep -q 'step' "$tmp/describe.log" || { cat "$tmp/describe.log"; fail "no key 'step' described"; }
step "ok"
