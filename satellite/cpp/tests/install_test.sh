#!/usr/bin/env bash
# Installs the satellite library into a temp prefix, builds a satellite out of tree against it
# twice (CMake package: satellite/examples/cpp/out-of-tree; pkg-config: a one-file program), and
# runs both against a hub: the pkg-config one publishes, the CMake one subscribes.
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
"$cmake" --install "$build" --prefix "$tmp/prefix" --component satellite
pc=$(find "$tmp/prefix" -name skrobot-satellite.pc)
libdir=$(dirname "$(dirname "$pc")")
for f in include/skrobot/satellite.h include/skrobot/satellite/satellite.h \
         include/skrobot/core/signal.h include/skrobot/flow/variant.h; do
  test -f "$tmp/prefix/$f" || { echo "missing $f"; exit 1; }
done
test -e "$libdir/libskrobot-satellite.so" || { echo "missing the library in $libdir"; exit 1; }
test -f "$libdir/cmake/skrobot_satellite/skrobot_satelliteConfig.cmake"

step "CMake package: configure and build satellite/examples/cpp/out-of-tree"
"$cmake" -S "$src/satellite/examples/cpp/out-of-tree" -B "$tmp/oot" \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_CXX_FLAGS="$cxxflags" \
  > "$tmp/oot.log" 2>&1 ||
  { cat "$tmp/oot.log"; exit 1; }
"$cmake" --build "$tmp/oot" > "$tmp/oot-build.log" 2>&1 || { cat "$tmp/oot-build.log"; exit 1; }

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
kill "$hello"
wait "$hello" || { echo "hello exited with $?"; cat "$tmp/hello.log"; exit 1; }
grep -q "hello 2" "$tmp/sub.log" || { cat "$tmp/sub.log"; exit 1; }
ldd "$tmp/oot/subscriber" | grep -q "$libdir/libskrobot-satellite" ||
  { echo "the out-of-tree build does not use the installed library"; ldd "$tmp/oot/subscriber"; exit 1; }
step "ok"
