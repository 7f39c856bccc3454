#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# An installed hub is complete and relocatable: `cmake --install` into a temporary prefix, then,
# with the source and build trees hidden (a mount namespace with empty tmpfs over them), a private
# /tmp and network (so the default config's /tmp/Robot and port 8080 are this test's own) and a
# clean environment, the installed hub
#   - lists every module from its own modules directory (--list-modules),
#   - started with no arguments uses the installed default config and serves the demo: the avatar
#     page and three.js over HTTP, the modules' channels to the installed flowctl,
#   - and the installed pysketch-executor runs a Python satellite against it.
#   installed_hub_test.sh BUILD_DIR SOURCE_DIR CMAKE "module;module;..."
set -euo pipefail
build=$1 src=$2 cmake=$3 modules=$4
if [[ ${INSIDE_NAMESPACE:-} != 1 ]]; then
  tmp=$(mktemp -d /var/tmp/skrobot-installed-XXXXXX)
  trap 'rm -rf "$tmp"' EXIT
  echo "== cmake --install into $tmp/prefix"
  "$cmake" --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log" 2>&1 ||
    { cat "$tmp/install.log"; exit 1; }
  for f in etc lib/systemd; do
    if [[ -e $tmp/prefix/$f ]]; then echo "FAIL: a plain install wrote $f"; exit 1; fi
  done
  # docs/cpp-satellites.md names the directory the libraries are installed in.
  lib=$(find "$tmp/prefix" -name 'libskrobot-satellite.so*' -printf '%h\n' | head -1)
  lib=${lib#"$tmp/prefix/"}
  grep -q "<prefix>/$lib\`" "$src/docs/cpp-satellites.md" ||
    { echo "FAIL: docs/cpp-satellites.md does not say the libraries go to <prefix>/$lib"; exit 1; }
  cp "$src/satellite/examples/python/publisher.py" "$tmp/"
  if [[ $(id -u) -eq 0 ]]; then ns=(unshare --mount --net); else ns=(unshare --map-root-user --mount --net); fi
  exec "${ns[@]}" env INSIDE_NAMESPACE=1 TMP="$tmp" bash "$0" "$@"
fi

# --- inside the namespace ---------------------------------------------------------------------
tmp=$TMP
fail() { echo "FAIL: $*" >&2; [[ -f $tmp/hub.log ]] && cat "$tmp/hub.log" >&2; exit 1; }
# The trees first: they may lie under /tmp, which is hidden next.
[[ -d $build ]] && mount -t tmpfs tmpfs "$build"
mount -t tmpfs tmpfs "$src"
mount -t tmpfs tmpfs /tmp
ip link set lo up
[[ -z $(ls -A "$src") ]] || fail "the source tree is still visible"
mkdir -p "$tmp/home" "$tmp/cwd"
cd "$tmp/cwd"
# A clean environment; an array, not a function, so that `"${run[@]}" prog &` is prog's own PID.
run=(env -i PATH=/usr/bin:/bin HOME="$tmp/home")
bin=$tmp/prefix/bin

echo "== --list-modules finds every module in the installed tree"
"${run[@]}" "$bin/skrobot" --list-modules > "$tmp/list.log" 2>&1 || { cat "$tmp/list.log"; fail "--list-modules"; }
IFS=';' read -r -a expected <<<"$modules"
for m in "${expected[@]}"; do
  grep -q "/skrobot/modules/$m.so" "$tmp/list.log" || { cat "$tmp/list.log"; fail "$m.so not listed"; }
done
echo "   ${#expected[@]} modules"

echo "== the hub, started with no arguments, serves the demo"
"${run[@]}" "$bin/skrobot" > "$tmp/hub.log" 2>&1 &
hub=$!
for _ in $(seq 600); do grep -q HUB-READY "$tmp/hub.log" && break; sleep 0.1; done
grep -q HUB-READY "$tmp/hub.log" || fail "no HUB-READY"
grep -q "config $tmp/prefix/share/skrobot/default.json" "$tmp/hub.log" ||
  fail "the hub did not use the installed default config"
# Every module that config/default.json enables has started.
for m in websocket-ui video-mono face-detect motion qrcode fft-audio speech nao-bridge; do
  grep "MODULE-STARTED" "$tmp/hub.log" | grep -q "$m" || fail "module $m did not start"
done
# Its satellite (config/default.json's "satellites"): the installed skrobot-asr, found in the hub's
# own bin directory, under the installed skrobot-reaper, logged in with the password made for it.
if [[ -x $bin/skrobot-asr ]]; then
  for _ in $(seq 300); do grep -q "SAT-READY asr" "$tmp/hub.log" && break; sleep 0.1; done
  grep -q "SAT-READY asr is up (logged in)" "$tmp/hub.log" || { cat "$tmp/hub.log"; fail "the asr satellite is not up"; }
fi
page=$(curl -sf http://127.0.0.1:8080/) || fail "no page on :8080"
grep -qi "<html" <<<"$page" || fail "the page is not HTML"
curl -sf -o "$tmp/three.js" http://127.0.0.1:8080/vendor/three.module.js || fail "no three.js"
[[ $(stat -c %s "$tmp/three.js") -gt 100000 ]] || fail "three.js is too small"
# The JavaScript library beside the page, for pages of the hub's web port (import '/skrobot/index.js').
lib=$(curl -sf http://127.0.0.1:8080/skrobot/index.js) || fail "no /skrobot/index.js"
grep -q "export async function connectPage" <<<"$lib" || fail "/skrobot/index.js is not the library"
# The same web port (server.web): the network page, and page tokens for it.
curl -sf http://127.0.0.1:8080/network | grep -q 'src="/js/network.js"' || fail "no network page on :8080"
curl -sf -X POST -H 'Sec-Fetch-Site: same-origin' http://127.0.0.1:8080/skrobot/token | grep -q '"user":"web-page"' ||
  fail "no page token for web-page on :8080"
"${run[@]}" "$bin/flowctl" ls > "$tmp/ls.log" 2>&1 || { cat "$tmp/ls.log"; fail "flowctl ls"; }
for c in websocket-ui.camera face-detect.faces speech.say nao-bridge.command; do
  grep -q "$c" "$tmp/ls.log" || { cat "$tmp/ls.log"; fail "flowctl ls does not list $c"; }
done

echo "== the installed pysketch-executor runs a satellite"
"${run[@]}" "$bin/pysketch-executor" "$tmp/publisher.py" > "$tmp/sketch.log" 2>&1 &
sketch=$!
"${run[@]}" "$bin/flowctl" echo guest.sine --wait --count 3 --format hex > "$tmp/echo.log" 2>&1 ||
  { cat "$tmp/echo.log" "$tmp/sketch.log"; fail "no data from the Python satellite"; }
[[ $(wc -l < "$tmp/echo.log") -ge 3 ]] || { cat "$tmp/echo.log"; fail "fewer than 3 messages"; }
kill "$sketch"; wait "$sketch" 2>/dev/null || true

kill -TERM "$hub"
rc=0; wait "$hub" || rc=$?
[[ $rc -eq 0 ]] || fail "the hub exited with $rc on SIGTERM"
echo "== ok"
