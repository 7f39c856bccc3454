#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# The board library's Arduino zip (cmake/arduino_zip.cmake, tools/bootstrap.sh package) as a user
# gets it: unzipped into a sketchbook's libraries folder, laid out as the Arduino library
# specification asks, self-contained, and every example built for the Uno from the unzipped
# folder (cmake/arduino.cmake, the flags of the Arduino IDE; a WiFi example with a WiFi library
# that does nothing).
#
#   arduino_zip_test.sh <source dir> <cmake>
set -euo pipefail
src=$1
cmake=$2
tmp=$(mktemp -d /tmp/skrobot-arduino-zip-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

zip=$("$cmake" -DSOURCE="$src/satellite/mcu" -DOUT="$tmp" -P "$src/cmake/arduino_zip.cmake" 2>&1)
[ -f "$zip" ] || fail "no zip: $zip"
mkdir -p "$tmp/sketchbook/libraries"
(cd "$tmp/sketchbook/libraries" && "$cmake" -E tar xf "$zip")
lib=$tmp/sketchbook/libraries/SkRobotFlow
[ -d "$lib" ] || fail "the zip does not hold one folder SkRobotFlow/: $(ls "$tmp/sketchbook/libraries")"

# library.properties: the fields the specification requires (url: none published yet).
props=$lib/library.properties
field() { sed -n "s/^$1=//p" "$props"; }
for f in name version author maintainer sentence paragraph category architectures includes; do
  [ -n "$(field "$f")" ] || fail "library.properties: $f is missing or empty"
done
[ "$(field name)" = SkRobotFlow ] || fail "library.properties: name is not the folder's name"
[[ "$(field version)" =~ ^[0-9]+\.[0-9]+\.[0-9]+$ ]] || fail "version is not X.Y.Z"
case "$(field category)" in
  Display|Communication|"Signal Input/Output"|Sensors|"Device Control"|Timing|"Data Storage"|\
  "Data Processing"|Other) ;;
  *) fail "category $(field category) is not one of the specification's" ;;
esac
for h in $(field includes | tr ',' ' '); do
  [ -f "$lib/src/$h" ] || fail "includes=$h: no src/$h"
done
# The host build's files stay out.
[ ! -e "$lib/CMakeLists.txt" ] && [ ! -e "$lib/posix" ] || fail "host build files in the zip"
# Self-contained: every quoted include of src/ is in src/.
for f in "$lib"/src/*; do
  for inc in $(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$f"); do
    [ -f "$lib/src/$inc" ] || fail "$(basename "$f") includes \"$inc\", which is not in src/"
  done
done

# Every example, for the Uno, from the unzipped library.
project=$tmp/project
mkdir -p "$project"
{
  echo "cmake_minimum_required(VERSION 3.20)"
  echo "project(skrobot_arduino_zip LANGUAGES NONE)"
  echo "include($src/cmake/arduino.cmake)"
  echo "if(NOT SKROBOT_ARDUINO_FOUND)"
  echo "  message(FATAL_ERROR \"missing: \${SKROBOT_ARDUINO_MISSING}\")"
  echo "endif()"
} > "$project/CMakeLists.txt"
examples=()
for dir in "$lib"/examples/*/; do
  name=$(basename "$dir")
  [ -f "$dir/$name.ino" ] || fail "examples/$name has no $name.ino"
  examples+=("$name")
  # The Uno has no radio: a WiFi sketch builds against tests/boards/null_wifi, a WiFi library that
  # does nothing (an ESP32's core is not in Debian).
  libs=$lib
  if grep -q '^#include <WiFi.h>' "$dir/$name.ino"; then libs="$lib $src/tests/boards/null_wifi"; fi
  echo "skrobot_add_sketch(${name,,} INO $dir/$name.ino LIBRARIES $libs)" >> "$project/CMakeLists.txt"
done
[ ${#examples[@]} -gt 0 ] || fail "no examples"
"$cmake" -S "$project" -B "$project/build" -G Ninja > "$tmp/configure.log" 2>&1 ||
  { cat "$tmp/configure.log"; fail "configuring the examples' build"; }
"$cmake" --build "$project/build" -j2 > "$tmp/build.log" 2>&1 ||
  { tail -40 "$tmp/build.log"; fail "building the examples"; }
for name in "${examples[@]}"; do
  size=$project/build/boards/${name,,}/${name,,}.size
  [ -f "$size" ] || fail "$name: no $size"
  echo "$name: $(tr '\n' ' ' < "$size")"
done
echo "OK: $(basename "$zip"), ${#examples[@]} example(s) built for the Uno"
