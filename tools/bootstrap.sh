#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Set-up for a fresh Debian 12 machine, then run the hub or the tests.
#
#   tools/bootstrap.sh run    install what is missing, build, start the hub with config/default.json
#   tools/bootstrap.sh test   install what is missing, build, run every test
#   tools/bootstrap.sh package  install what is missing, build, make the Debian packages
#                               (build/packages/skrobot_*.deb, skrobot-dev_*.deb; docs/install.md)
#                               and the JavaScript library's npm tarball (skrobot-*.tgz)
#
# Idempotent: packages already installed and an up-to-date build are left alone.
set -euo pipefail

cd "$(dirname "$0")/.."
ROOT=$(pwd)
MODE=${1:-}
case "$MODE" in
  run|test|build|package) ;;
  *) echo "usage: tools/bootstrap.sh run|test|build|package" >&2; exit 2 ;;
esac
shift || true

JOBS=$(nproc 2>/dev/null || echo 2)
# Tests mostly wait (on hubs, sockets, timers): one more at a time than there are cores keeps the
# cores busy; the timing-sensitive ones run alone whatever this is (RUN_SERIAL, docs/testing.md).
TEST_JOBS=${TEST_JOBS:-$((JOBS + 1))}
STEP=0
# Each step says how long the one before it took, so that a slow run shows where its time went.
STEP_START=$SECONDS
step() {
  if ((STEP > 0)); then echo "    (step $STEP: $((SECONDS - STEP_START)) s)"; fi
  STEP=$((STEP + 1))
  STEP_START=$SECONDS
  echo "==> [$STEP] $*"
}
trap 'if ((STEP > 0)); then echo "    (step $STEP: $((SECONDS - STEP_START)) s; $SECONDS s in all)"; fi' EXIT

# Debian packages the build, the hub and the tests need.
PACKAGES=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libuv1-dev libjsoncpp-dev libsodium-dev
  # TLS on the TCP transport (libssl-dev), and the test certificates (openssl)
  libssl-dev openssl
  googletest libgtest-dev
  clang libclang-rt-14-dev
  python3 python3-pip python3-setuptools python3-lib2to3
  # vision modules, and their test data (opencv-doc, python3-skimage, qrencode)
  libopencv-dev opencv-data opencv-doc python3-skimage python3-numpy python3-opencv qrencode libzbar-dev
  # audio modules, and the null sound device of their tests
  libfftw3-dev portaudio19-dev libasound2-dev alsa-utils libespeak-ng-dev espeak-ng
  libvorbis-dev libogg-dev sox
  # the speech-recognition satellite (satellite/asr) and its test recordings
  libpocketsphinx-dev pocketsphinx-en-us pocketsphinx-testdata
  # websocket-ui and its browser tests
  libwebsockets-dev chromium
  # nats-bridge (the C client) and its tests and benchmark (a real server on loopback)
  libnats-dev nats-server
  # bench/peers: the hub beside Redis and Mosquitto (servers and client libraries; NATS above)
  redis-server libhiredis-dev mosquitto libmosquitto-dev
  # ros2-bridge: eProsima Fast DDS (the DDS of ROS 2's default middleware) and its CDR library
  libfastrtps-dev libfastcdr-dev
  # its tests' second DDS vendor on the wire: Cyclone DDS peers (tests/ros2/peers; idlc generates their types)
  cyclonedds-dev cyclonedds-tools
  # fastddsgen (Java): CTest ros2.fastddsgen_regenerate checks the committed Fast DDS peer types
  # (tests/ros2/peers/fastdds_gen) against it; 31 packages, 37 MB, ~11 s where a JRE already is
  fastddsgen
  # flowctl record/play (MCAP chunks compressed with zstd or lz4)
  libzstd-dev liblz4-dev
  # the Debian packages (CPack, dpkg-shlibdeps) and their tests (namespaces, the unit's check)
  dpkg-dev iproute2 curl systemd
  # the board library's tests: Arduino sketches built for the Uno and run in simavr (tests/boards)
  gcc-avr avr-libc arduino-core-avr libsimavr-dev libsimavrparts1 libelf-dev
)

# Node.js and npm for the web page's packages and its browser tests: Debian's, unless the machine
# already has a node (e.g. from NodeSource, whose nodejs package brings its own npm).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then PACKAGES+=(nodejs npm); fi

step "checking Debian packages (${#PACKAGES[@]})"
missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if ((${#missing[@]} > 0)); then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null; then SUDO=sudo; else
      echo "need root to install: ${missing[*]}" >&2; exit 1
    fi
  fi
  step "installing ${missing[*]} (apt-get, a few minutes on a fresh machine)"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -q
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "    all present"
fi

build_preset() {
  local preset=$1
  step "configuring ($preset preset, build/$preset)"
  cmake --preset "$preset" >/dev/null
  step "building ($preset, $JOBS jobs)"
  cmake --build --preset "$preset" -j "$JOBS"
}

step "installing the web page's npm packages (three.js, playwright-core, ws, and the MCAP and Foxglove reference implementations) into web/node_modules"
if [ ! -f web/node_modules/.package-lock.json ] || [ web/package-lock.json -nt web/node_modules/.package-lock.json ]; then
  npm ci --prefix web --no-audit --no-fund --loglevel=error
else
  echo "    up to date"
fi
step "installing the JavaScript library's npm package (typescript, for its declarations' test) into satellite/js/node_modules"
if [ ! -f satellite/js/node_modules/.package-lock.json ] ||
   [ satellite/js/package-lock.json -nt satellite/js/node_modules/.package-lock.json ]; then
  npm ci --prefix satellite/js --no-audit --no-fund --loglevel=error
else
  echo "    up to date"
fi

build_preset release

step "installing the PySketch Python package (pysketch-executor on PATH)"
PIP=(/usr/bin/python3 -m pip install --quiet --break-system-packages --no-build-isolation --no-deps
     --no-index "$ROOT/satellite/python")
if [ "$(id -u)" -eq 0 ]; then "${PIP[@]}"; elif command -v sudo >/dev/null; then sudo "${PIP[@]}"; fi
rm -rf "$ROOT/satellite/python/build" "$ROOT"/satellite/python/*.egg-info

case "$MODE" in
  build)
    echo "built: build/release/bin/skrobot"
    ;;
  package)
    step "making the Debian packages (cpack, build/packages)"
    cpack --config build/release/CPackConfig.cmake -B build/packages > build/packages.log 2>&1 ||
      { cat build/packages.log; exit 1; }
    rm -rf build/packages/_CPack_Packages
    # The board library as an Arduino library zip (docs/microcontrollers.md).
    cmake -DSOURCE=satellite/mcu -DOUT=build/packages -P cmake/arduino_zip.cmake > /dev/null
    # The JavaScript library as an npm tarball (satellite/js; npm install ./skrobot-*.tgz).
    (cd satellite/js && npm pack --pack-destination "$ROOT/build/packages" --loglevel=error > /dev/null)
    ls -1 build/packages/*.deb build/packages/SkRobotFlow-*.zip build/packages/skrobot-*.tgz
    echo "install them with: sudo apt install ./build/packages/skrobot_*.deb [./build/packages/skrobot-dev_*.deb]"
    ;;
  run)
    # The hub starts its satellites itself (config/default.json's "satellites": the speech
    # recogniser; docs/robot.md) and stops them with it.
    step "starting the hub: build/release/bin/skrobot --config config/default.json (Ctrl-C stops it)"
    exec "$ROOT/build/release/bin/skrobot" --config "$ROOT/config/default.json" "$@"
    ;;
  test)
    # docs/testing.md: what each step runs, and the heavy tests the asan build leaves out.
    build_preset asan
    step "running the tests under AddressSanitizer + UndefinedBehaviorSanitizer (build/asan; the heavy ones in release only)"
    ctest --preset asan -j "$TEST_JOBS" "$@"
    step "fuzzing the network decoders (clang + libFuzzer, ${FUZZ_CHANGED_SECONDS:-60} s per target whose code changed, ${FUZZ_SECONDS:-10} s for the others)"
    fuzz_status=0
    tools/fuzz.sh || fuzz_status=$?
    # Said now too: a failure of the release tests below ends the script before its last line.
    if [ "$fuzz_status" -ne 0 ]; then echo "the fuzzers failed (above); the release tests run all the same"; fi
    step "running the tests (release build)"
    ctest --preset release -j "$TEST_JOBS" "$@"
    if [ "$fuzz_status" -ne 0 ]; then echo "the fuzzers found a failure (above)"; fi
    exit "$fuzz_status"
    ;;
esac
