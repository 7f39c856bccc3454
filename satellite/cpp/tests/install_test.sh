#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs the runtime and dev components (libskrobot-satellite, libskrobot-runtime, their
# headers, the CMake package and the .pc) into a temp prefix, builds a satellite out of tree against it twice
# (CMake package: satellite/examples/cpp/out-of-tree; pkg-config: a one-file program), and runs
# both against a hub: the pkg-config one publishes, the CMake one subscribes. A third program
# links skrobot::runtime alone (a Loop, a Variant, an address) and must not need the satellite
# library; the installed flowctl (component flowctl) must find both libraries from its prefix.
#   install_test.sh BUILD_DIR SOURCE_DIR SKROBOT_BIN CMAKE CXX [CXX_FLAGS]
# CXX_FLAGS are the build's own (sanitizers must match between the library and its users).
set -euo pipefail
build=$1 src=$2 skrobot=$3 cmake=$4 cxx=$5 cxxflags=${6:-}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/skrobot-install-XXXXXX")
hub=""
cleanup() {
  if [[ -n $hub ]]; then kill "$hub" 2>/dev/null || true; wait "$hub" 2>/dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
step() { echo "== $*"; }

step "install into $tmp/prefix"
"$cmake" --install "$build" --prefix "$tmp/prefix" --component runtime
"$cmake" --install "$build" --prefix "$tmp/prefix" --component dev
pc=$(find "$tmp/prefix" -name skrobot-satellite.pc)
libdir=$(dirname "$(dirname "$pc")")
for f in include/skrobot/satellite.h include/skrobot/satellite/satellite.h \
         include/skrobot/satellite/address.h include/skrobot/result.hpp \
         include/skrobot/core/signal.h include/skrobot/core/loop.h include/skrobot/core/result.h \
         include/skrobot/flow/variant.h include/skrobot/flow/codec.h include/skrobot/flow/address.h; do
  test -f "$tmp/prefix/$f" || { echo "missing $f"; exit 1; }
done
for l in libskrobot-satellite.so libskrobot-runtime.so; do
  test -e "$libdir/$l" || { echo "missing $l in $libdir"; exit 1; }
done
test -f "$libdir/cmake/skrobot_satellite/skrobot_satelliteConfig.cmake"
grep -q "skrobot::runtime" "$libdir/cmake/skrobot_satellite/skrobot_satelliteTargets.cmake" ||
  { echo "the CMake package does not export skrobot::runtime"; exit 1; }

step "CMake package: configure and build satellite/examples/cpp/out-of-tree"
"$cmake" -S "$src/satellite/examples/cpp/out-of-tree" -B "$tmp/oot" \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_CXX_FLAGS="$cxxflags" \
  > "$tmp/oot.log" 2>&1 ||
  { cat "$tmp/oot.log"; exit 1; }
"$cmake" --build "$tmp/oot" > "$tmp/oot-build.log" 2>&1 || { cat "$tmp/oot-build.log"; exit 1; }

step "CMake package: a program on skrobot::runtime alone (Loop, Variant, address)"
mkdir -p "$tmp/rt-src"
cat > "$tmp/rt-src/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.16)
project(runtime_only LANGUAGES CXX)
find_package(skrobot_satellite REQUIRED)
add_executable(runtime_only main.cpp)
target_link_libraries(runtime_only PRIVATE skrobot::runtime)
CMAKE
# The old include paths on purpose: their forwarding headers must keep a program written for
# them building until the next minor release (CHANGELOG.md, "Moved headers").
cat > "$tmp/rt-src/main.cpp" <<'CPP'
#include <skrobot/core/loop.h>
#include <skrobot/flow/address.h>
#include <skrobot/flow/bytes.h>
#include <skrobot/flow/variant.h>
#include <cstdio>
#include <string>
int main() {
  using skr::flow::Variant;
  std::string wire;
  skr::flow::ByteWriter out(wire);
  skr::flow::encodeVariant(Variant(Variant::Map{{"rate_hz", 30}, {"name", "cam"}}), out);
  skr::flow::ByteReader in(wire);
  auto back = skr::flow::decodeVariant(in);
  if (!back) return 1;
  auto addr = skr::flow::Address::parse("tcp:[::1]:9100");
  if (!addr) return 1;
  skr::Loop loop;
  int ticks = 0;
  loop.addTickHandler(skr::Tick::fast, [&] {
    if (++ticks == 3) loop.stop();
  });
  loop.post([&] { std::printf("%s %s ", skr::flow::variantToJsonText(*back).c_str(),
                              addr->toString().c_str()); });
  loop.run();
  std::printf("ticks %d\n", ticks);
  return 0;
}
CPP
"$cmake" -S "$tmp/rt-src" -B "$tmp/rt" \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_CXX_FLAGS="$cxxflags" \
  > "$tmp/rt.log" 2>&1 || { cat "$tmp/rt.log"; exit 1; }
"$cmake" --build "$tmp/rt" > "$tmp/rt-build.log" 2>&1 || { cat "$tmp/rt-build.log"; exit 1; }
rt_out=$("$tmp/rt/runtime_only")
echo "runtime_only: $rt_out"
[[ $rt_out == '{"name":"cam","rate_hz":30} tcp:[::1]:9100 ticks 3' ]] ||
  { echo "runtime_only printed the wrong thing"; exit 1; }
deps=$(ldd "$tmp/rt/runtime_only")  # captured: `ldd | grep -q` fails on SIGPIPE with pipefail
grep -q "$libdir/libskrobot-runtime" <<<"$deps" ||
  { echo "runtime_only does not use the installed runtime"; echo "$deps"; exit 1; }
if grep -q libskrobot-satellite <<<"$deps"; then
  echo "runtime_only needs the satellite library"; exit 1
fi

step "pkg-config: compile a one-file satellite"
cat > "$tmp/hello.cpp" <<'CPP'
#include <skrobot/satellite.h>
#include <string>
struct Hello : skr::sat::Sketch {
  using Sketch::Sketch;
  void setup() override { (void)satellite().addChannel({.name = "hello"}); }
  void loop() override {
    if (satellite().hasSubscribers("hello")) (void)satellite().publish("hello", "hello " + std::to_string(n++));
  }
  int n = 0;
};
int main() { Hello h; return h.run(); }
CPP
flags=$(PKG_CONFIG_PATH="$libdir/pkgconfig" pkg-config --cflags --libs skrobot-satellite)
echo "pkg-config: $flags"
# shellcheck disable=SC2086
"$cxx" $cxxflags "$tmp/hello.cpp" $flags -Wl,-rpath,"$libdir" -o "$tmp/hello"

step "run both against a hub"
cat > "$tmp/hub.json" <<JSON
{"app_name": "skrobot-install-$$", "data_dir": "$tmp/data", "server": {"unix_path": "$tmp/hub.sock"},
 "accounts": {"dev_account": {"user": "guest", "password": "password"}}, "modules": []}
JSON
"$skrobot" --config "$tmp/hub.json" > "$tmp/hub.log" 2>&1 &
hub=$!
for _ in $(seq 300); do grep -q HUB-READY "$tmp/hub.log" && break; sleep 0.1; done
grep -q HUB-READY "$tmp/hub.log" || { cat "$tmp/hub.log"; exit 1; }
export ROBOT_ADDRESS="local:$tmp/hub.sock"
"$tmp/hello" > "$tmp/hello.log" 2>&1 &
hello=$!
timeout 60 "$tmp/oot/subscriber" guest.hello 3 > "$tmp/sub.log" 2>&1 || { cat "$tmp/sub.log"; exit 1; }

step "the installed flowctl finds its libraries in the prefix and lists guest.hello"
"$cmake" --install "$build" --prefix "$tmp/prefix" --component flowctl > /dev/null
deps=$(ldd "$tmp/prefix/bin/flowctl")
grep -q "libskrobot-runtime.so.0 => $tmp/prefix/" <<<"$deps" ||
  { echo "the installed flowctl does not use the installed runtime"; echo "$deps"; exit 1; }
"$tmp/prefix/bin/flowctl" ls > "$tmp/ls.log" 2>&1 || { cat "$tmp/ls.log"; exit 1; }
grep -q "guest.hello" "$tmp/ls.log" || { echo "flowctl ls does not list guest.hello"; cat "$tmp/ls.log"; exit 1; }

kill "$hello"
wait "$hello" || { echo "hello exited with $?"; cat "$tmp/hello.log"; exit 1; }
grep -q "hello 2" "$tmp/sub.log" || { cat "$tmp/sub.log"; exit 1; }
deps=$(ldd "$tmp/oot/subscriber")
grep -q "$libdir/libskrobot-satellite" <<<"$deps" ||
  { echo "the out-of-tree build does not use the installed library"; echo "$deps"; exit 1; }
step "ok"
