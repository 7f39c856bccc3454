#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Plugin ABI compatibility with modules compiled now, with the build's C compiler and flags,
# against: the frozen 1.0 to 1.10 headers (abi/1.0, abi/1.1: module_1_0.c, module_1_1.c;
# abi/1.2 to abi/1.10: module_current.c as it was), the
# current plugin.h, and copies of it with the minor or the major raised by one (module_current.c).
# The hub (--check-config, then a real start and SIGTERM) must load and run the older and current
# modules with the values of their config, and refuse the newer minor and the other major with
# MODULE-ABI naming both versions, after reading only their descriptors' 8-byte header (the
# *_header_only builds have nothing readable after it), and go on with the others.
#   abi_compat_test.sh SKROBOT_BIN PLUGIN_INCLUDE_DIR CC [C_FLAGS] [MODULE_LINKER_FLAGS]
# C_FLAGS and MODULE_LINKER_FLAGS are the build's (sanitizers must match the hub's). ABI_KEEP=1
# keeps the temp dir (modules, configs, outputs) for a look after a failure.
set -euo pipefail
skrobot=$(readlink -f "$1") include=$(readlink -f "$2") cc=$3 cflags=${4:-} ldflags=${5:-}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/skrobot-abi-XXXXXX")
hub=""
cleanup() {
  if [[ -n $hub ]]; then kill "$hub" 2>/dev/null || true; wait "$hub" 2>/dev/null || true; fi
  if [[ -n ${ABI_KEEP:-} ]]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
step() { echo "== $*"; }
fail() {
  echo "FAIL: $*"
  exit 1
}
# expect FILE TEXT: the output holds TEXT (a fixed string).
expect() { grep -qF -- "$2" "$1" || { cat "$1"; fail "no '$2' in $(basename "$1")"; }; }
refuse() { ! grep -qF -- "$2" "$1" || { cat "$1"; fail "'$2' in $(basename "$1")"; }; }

current=$include/skrobot/plugin.h
major=$(sed -n 's/^#define SKR_PLUGIN_ABI_MAJOR \([0-9]*\)$/\1/p' "$current")
minor=$(sed -n 's/^#define SKR_PLUGIN_ABI_MINOR \([0-9]*\)$/\1/p' "$current")
[[ -n $major && -n $minor ]] || fail "no SKR_PLUGIN_ABI_MAJOR/MINOR in $current"
cur=$major.$minor newer=$major.$((minor + 1)) other=$((major + 1)).0
step "hub ABI $cur; modules for 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 1.10, $cur, $newer (refused), $other (refused)"

# A copy of the current header with the version macros replaced (it includes no other header of
# ours, so the copy stands alone).
grep -q '#include "' "$current" && fail "plugin.h includes a local header: copy it too"
raised() {  # raised DIR MAJOR MINOR
  mkdir -p "$1/skrobot"
  sed -e "s/^#define SKR_PLUGIN_ABI_MAJOR .*/#define SKR_PLUGIN_ABI_MAJOR $2/" \
      -e "s/^#define SKR_PLUGIN_ABI_MINOR .*/#define SKR_PLUGIN_ABI_MINOR $3/" \
      "$current" > "$1/skrobot/plugin.h"
  if ! grep -q "^#define SKR_PLUGIN_ABI_MAJOR $2\$" "$1/skrobot/plugin.h" ||
    ! grep -q "^#define SKR_PLUGIN_ABI_MINOR $3\$" "$1/skrobot/plugin.h"; then
    fail "could not raise the version in a copy of $current"
  fi
}
raised "$tmp/include-$newer" "$major" $((minor + 1))
raised "$tmp/include-$other" $((major + 1)) 0

mods=$tmp/modules
mkdir -p "$mods"
build() {  # build NAME SOURCE INCLUDE_DIR [CFLAGS...]
  local name=$1 src=$2 inc=$3
  shift 3
  # shellcheck disable=SC2086  # the build's flags are words
  "$cc" $cflags -Wall -Wextra -Wpedantic -Werror -fPIC -fvisibility=hidden "$@" -I "$inc" \
    -shared -o "$mods/$name.so" "$here/$src" $ldflags -Wl,--no-undefined ||
    fail "cannot compile $src against $inc"
}
step "compile with $cc $cflags"
build abi_1_0 module_1_0.c "$here/1.0"
build abi_1_1 module_1_1.c "$here/1.1"
# 1.2 is module_current.c as it was built against the released 1.2 header (declared keys).
build abi_1_2 module_current.c "$here/1.2"
build abi_1_3 module_current.c "$here/1.3"
build abi_1_4 module_current.c "$here/1.4"
build abi_1_5 module_current.c "$here/1.5"
build abi_1_6 module_current.c "$here/1.6"
build abi_1_7 module_current.c "$here/1.7"
build abi_1_8 module_current.c "$here/1.8"
build abi_1_9 module_current.c "$here/1.9"
build abi_1_10 module_current.c "$here/1.10"
build "abi_${major}_$minor" module_current.c "$include"
build "abi_${major}_$((minor + 1))" module_current.c "$tmp/include-$newer"
build "abi_${major}_$((minor + 1))_header_only" module_current.c "$tmp/include-$newer" \
  -DABI_TEST_HEADER_ONLY
build "abi_$((major + 1))_0_header_only" module_current.c "$tmp/include-$other" \
  -DABI_TEST_HEADER_ONLY

cur_mod=abi_${major}_$minor
newer_mod=abi_${major}_$((minor + 1))
cur_tag=ABI$major$minor-INIT
newer_tag=ABI$major$((minor + 1))-INIT
# Refused modules between the working ones: the hub goes on after each. The old modules get a
# key they do not read (they declare no keys: their config is unchecked); the current module gets
# its declared default count.
cat > "$tmp/hub.json" <<JSON
{ "app_name": "skrobot-abi-$$", "data_dir": "data", "module_paths": ["$mods"],
  "modules": [
    { "name": "abi_1_0", "config": { "count": 3, "label": "old", "unread": true } },
    { "name": "$newer_mod", "config": { "label": "newer" } },
    { "name": "abi_1_1", "config": { "count": 4, "label": "one-one", "unread": 1 } },
    { "name": "${newer_mod}_header_only" },
    { "name": "abi_$((major + 1))_0_header_only" },
    { "name": "abi_1_2", "config": { "count": 7, "label": "one-two" } },
    { "name": "abi_1_3", "config": { "count": 8, "label": "one-three" } },
    { "name": "abi_1_4", "config": { "count": 9, "label": "one-four" } },
    { "name": "abi_1_5", "config": { "count": 10, "label": "one-five" } },
    { "name": "abi_1_6", "config": { "count": 11, "label": "one-six" } },
    { "name": "abi_1_7", "config": { "count": 12, "label": "one-seven" } },
    { "name": "abi_1_8", "config": { "count": 13, "label": "one-eight" } },
    { "name": "abi_1_9", "config": { "count": 14, "label": "one-nine" } },
    { "name": "abi_1_10", "config": { "count": 15, "label": "one-ten" } },
    { "name": "$cur_mod", "config": { "label": "current" } }
  ] }
JSON

step "skrobot --check-config"
rc=0
"$skrobot" --config "$tmp/hub.json" --check-config > "$tmp/check.txt" 2>&1 || rc=$?
[[ $rc == 1 ]] || { cat "$tmp/check.txt"; fail "--check-config exited $rc, expected 1"; }
expect "$tmp/check.txt" "(ABI 1.0)"
expect "$tmp/check.txt" "(ABI 1.1)"
expect "$tmp/check.txt" "(ABI 1.2)"
expect "$tmp/check.txt" "(ABI 1.3)"
expect "$tmp/check.txt" "(ABI 1.4)"
expect "$tmp/check.txt" "(ABI 1.5)"
expect "$tmp/check.txt" "(ABI 1.6)"
expect "$tmp/check.txt" "(ABI 1.7)"
expect "$tmp/check.txt" "(ABI 1.8)"
expect "$tmp/check.txt" "(ABI 1.9)"
expect "$tmp/check.txt" "(ABI 1.10)"
expect "$tmp/check.txt" "(ABI $cur)"
for m in "$newer_mod" "${newer_mod}_header_only"; do
  grep -E "^ +$m +MODULE-ABI .*built for ABI $newer, this hub has ABI $cur" "$tmp/check.txt" \
    > /dev/null || { cat "$tmp/check.txt"; fail "$m not refused as a newer minor"; }
done
grep -E "MODULE-ABI .*built for ABI $other, this hub has ABI $cur" "$tmp/check.txt" \
  > /dev/null || { cat "$tmp/check.txt"; fail "the other major is not refused"; }
expect "$tmp/check.txt" "3 of 15 enabled modules would fail to load"
refuse "$tmp/check.txt" "-INIT"

step "skrobot --describe-module: old modules declare no keys"
for m in abi_1_0 abi_1_1; do
  "$skrobot" --describe-module "$mods/$m.so" > "$tmp/describe.txt" 2>&1 ||
    { cat "$tmp/describe.txt"; fail "--describe-module $m failed"; }
  expect "$tmp/describe.txt" "config: not declared"
done

step "skrobot --check-config: the current module's declared keys are checked"
cat > "$tmp/bad.json" <<JSON
{ "module_paths": ["$mods"], "modules": [ { "name": "$cur_mod", "config": { "count": 101 } } ] }
JSON
rc=0
"$skrobot" --config "$tmp/bad.json" --check-config > "$tmp/bad.txt" 2>&1 || rc=$?
[[ $rc == 1 ]] || { cat "$tmp/bad.txt"; fail "--check-config exited $rc, expected 1"; }
expect "$tmp/bad.txt" 'MODULE-CONFIG $.modules[0].config.count: must be <= 100, got 101'
expect "$tmp/bad.txt" 'MODULE-CONFIG $.modules[0].config.label: required key missing'

step "skrobot: start, run, SIGTERM"
(cd "$tmp" && exec "$skrobot" --config "$tmp/hub.json" > "$tmp/hub.log" 2>&1) &
hub=$!
for _ in $(seq 3000); do  # up to 30 s on a loaded machine
  grep -q "HUB-READY" "$tmp/hub.log" && break
  kill -0 "$hub" 2>/dev/null || break
  sleep 0.01
done
kill -TERM "$hub" 2>/dev/null || true
rc=0
wait "$hub" || rc=$?
hub=""
[[ $rc == 0 ]] || { cat "$tmp/hub.log"; fail "the hub exited $rc"; }
log=$tmp/hub.log
expect "$log" "12 modules running, 3 failed"
expect "$log" "ABI10-INIT count=3 label=old host=$cur"
expect "$log" "ABI10-START abi_1_0"
expect "$log" "ABI10-STOP abi_1_0"
expect "$log" "ABI10-FINI abi_1_0"
expect "$log" "ABI11-INIT count=4 label=one-one"
expect "$log" "ABI11-DATA count=4"
expect "$log" 'ABI11-DB "count=4"'
expect "$log" "ABI12-INIT count=7 label=one-two has_count=1"
expect "$log" "ABI13-INIT count=8 label=one-three has_count=1"
expect "$log" "ABI14-INIT count=9 label=one-four has_count=1"
expect "$log" "ABI15-INIT count=10 label=one-five has_count=1"
expect "$log" "ABI16-INIT count=11 label=one-six has_count=1"
expect "$log" "ABI17-INIT count=12 label=one-seven has_count=1"
expect "$log" "ABI18-INIT count=13 label=one-eight has_count=1"
expect "$log" "ABI19-INIT count=14 label=one-nine has_count=1"
expect "$log" "ABI110-INIT count=15 label=one-ten has_count=1"
expect "$log" "$cur_tag count=5 label=current has_count=1"
for m in abi_1_0 abi_1_1 abi_1_2 abi_1_3 abi_1_4 abi_1_5 abi_1_6 abi_1_7 abi_1_8 abi_1_9 abi_1_10 "$cur_mod"; do expect "$log" "MODULE-STOPPED module $m"; done
for m in "$newer_mod" "${newer_mod}_header_only"; do
  grep -E "MODULE-ABI module $m .*built for ABI $newer, this hub has ABI $cur" "$log" \
    > /dev/null || { cat "$log"; fail "$m not refused as a newer minor"; }
done
grep -E "MODULE-ABI module abi_$((major + 1))_0_header_only .*built for ABI $other, this hub has ABI $cur" \
  "$log" > /dev/null || { cat "$log"; fail "the other major is not refused"; }
refuse "$log" "$newer_tag"
refuse "$log" "ABI$((major + 1))0-INIT"
step "ok"
