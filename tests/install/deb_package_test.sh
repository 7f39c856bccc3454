#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Debian packages: built with CPack from this build, their file lists, control data and
# systemd unit checked, then unpacked into a throwaway root (dpkg -x) and run from there with the
# source and build trees hidden, a clean environment, and private /tmp, /run, /var/lib and network
# (a mount and network namespace): the packaged config (no development account, socket in
# /run/skrobot, data in /var/lib/skrobot) serves the demo to an account made with `skrobot user`.
#   deb_package_test.sh BUILD_DIR SOURCE_DIR CPACK "module;module;..."
set -euo pipefail
build=$1 src=$2 cpack=$3 modules=$4
fail() { echo "FAIL: $*" >&2; [[ -f ${tmp:-}/hub.log ]] && cat "$tmp/hub.log" >&2; exit 1; }
IFS=';' read -r -a expected_modules <<<"$modules"

if [[ ${INSIDE_NAMESPACE:-} != 1 ]]; then
  tmp=$(mktemp -d /var/tmp/skrobot-deb-XXXXXX)
  trap 'rm -rf "$tmp"' EXIT
  echo "== cpack"
  "$cpack" --config "$build/CPackConfig.cmake" -B "$tmp/pkg" > "$tmp/cpack.log" 2>&1 ||
    { cat "$tmp/cpack.log"; fail "cpack"; }
  hub_deb=$(ls "$tmp"/pkg/skrobot_*.deb) dev_deb=$(ls "$tmp"/pkg/skrobot-dev_*.deb)
  echo "   $(basename "$hub_deb") $(( $(stat -c %s "$hub_deb") / 1024 )) KiB," \
       "$(basename "$dev_deb") $(( $(stat -c %s "$dev_deb") / 1024 )) KiB"

  echo "== file lists"
  dpkg-deb -c "$hub_deb" | awk '{print $6}' | sed 's|^\./|/|' > "$tmp/hub.files"
  dpkg-deb -c "$dev_deb" | awk '{print $6}' | sed 's|^\./|/|' > "$tmp/dev.files"
  arch=$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || gcc -print-multiarch)
  lib=/usr/lib/$arch
  need() { grep -qx "$2" "$tmp/$1.files" || fail "$1 package lacks $2"; }
  never() { if grep -q "$2" "$tmp/$1.files"; then fail "$1 package has $2: $(grep "$2" "$tmp/$1.files" | head -3)"; fi; }
  for f in /usr/bin/skrobot /usr/bin/flowctl /usr/bin/pysketch-executor \
           "$lib/libskrobot-runtime.so.0" "$lib/libskrobot-satellite.so.0" \
           /usr/share/skrobot/default.json /usr/share/skrobot/web/index.html \
           /usr/share/skrobot/web/vendor/three.module.js /usr/share/skrobot/web/vendor/LICENSE \
           /usr/share/skrobot/web/skrobot/index.js /usr/share/skrobot/web/skrobot/media-codes.js \
           /usr/share/doc/skrobot/README.md /usr/share/doc/skrobot/copyright \
           /usr/share/doc/skrobot/LICENSE /usr/share/doc/skrobot/NOTICE \
           /usr/lib/python3/dist-packages/PySketch/flowsat.py \
           /etc/skrobot/skrobot.json /lib/systemd/system/skrobot.service; do
    need hub "$f"
  done
  for m in "${expected_modules[@]}"; do need hub "$lib/skrobot/modules/$m.so"; done
  never hub '^/usr/include/'; never hub '\.a$'; never hub '/cmake/'; never hub '/pkgconfig/'
  never hub 'libskrobot-runtime\.so$'; never hub '__pycache__'
  for f in /usr/include/skrobot/plugin.h /usr/include/skrobot/plugin.hpp \
           /usr/include/skrobot/support/config.hpp /usr/include/skrobot/satellite.h \
           /usr/include/skrobot/core/loop.h "$lib/libskrobot-module-support.a" \
           "$lib/libskrobot-runtime.so" "$lib/libskrobot-satellite.so" \
           "$lib/cmake/skrobot_module/skrobot_moduleConfig.cmake" \
           "$lib/cmake/skrobot_module/SkrobotModule.cmake" \
           "$lib/cmake/skrobot_satellite/skrobot_satelliteConfig.cmake" \
           "$lib/pkgconfig/skrobot-module.pc" "$lib/pkgconfig/skrobot-satellite.pc" \
           /usr/share/doc/skrobot-dev/copyright; do
    need dev "$f"
  done
  never dev '/skrobot/modules/'; never dev '^/usr/bin/'; never dev '\.so\.0'

  echo "== control data"
  depends=$(dpkg-deb -f "$hub_deb" Depends)
  for d in adduser python3 libuv1 libopencv libwebsockets; do
    grep -q "$d" <<<"$depends" || fail "Depends lacks $d: $depends"
  done
  grep -q "skrobot (= " <<<"$(dpkg-deb -f "$dev_deb" Depends)" || fail "skrobot-dev does not depend on skrobot"
  dpkg-deb -e "$hub_deb" "$tmp/control"
  grep -qx /etc/skrobot/skrobot.json "$tmp/control/conffiles" || fail "the config is no conffile"
  for s in postinst prerm postrm; do
    [[ -x $tmp/control/$s ]] || fail "no executable $s"
    sh -n "$tmp/control/$s" || fail "$s: syntax"
  done

  echo "== unpacked into $tmp/root"
  dpkg -x "$hub_deb" "$tmp/root"
  dpkg -x "$dev_deb" "$tmp/root"
  cp "$src/satellite/examples/python/publisher.py" "$tmp/"
  python3 - "$tmp/root/etc/skrobot/skrobot.json" <<'PY' || fail "the packaged config"
import json, sys
c = json.load(open(sys.argv[1]))
assert "dev_account" not in c.get("accounts", {}), "a development account is configured"
assert c["server"]["unix_path"] == "/run/skrobot/Robot", c["server"]
assert c["data_dir"] == "/var/lib/skrobot", c.get("data_dir")
assert not c["server"].get("tcp", False), "TCP is on"
PY
  # Each package's copyright file is machine-readable (DEP-5) and names the project's licence.
  for doc in skrobot skrobot-dev; do
    copyright=$tmp/root/usr/share/doc/$doc/copyright
    head -1 "$copyright" | grep -qx 'Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/' ||
      fail "$doc's copyright file is not DEP-5"
    grep -A2 -x 'Files: \*' "$copyright" | grep -qx 'License: Apache-2.0' ||
      fail "$doc's copyright file does not put Files: * under Apache-2.0"
  done
  unit=$tmp/root/lib/systemd/system/skrobot.service
  for line in User=skrobot Group=skrobot RuntimeDirectory=skrobot StateDirectory=skrobot \
              "ExecStart=/usr/bin/skrobot --config /etc/skrobot/skrobot.json" PrivateTmp=yes; do
    grep -qx "$line" "$unit" || fail "the unit lacks $line"
  done
  if command -v systemd-analyze > /dev/null; then
    echo "== systemd-analyze verify"
    # Against the throwaway root (its ExecStart must exist there) with this machine's targets; a
    # warning (an unknown key, a bad value: systemd ignores the line) fails as an error does.
    mkdir -p "$tmp/verify-root"
    cp -a "$tmp/root/." "$tmp/verify-root/"
    cp -a /lib/systemd/system/*.target "$tmp/verify-root/lib/systemd/system/"
    rc=0
    systemd-analyze verify --man=no --root="$tmp/verify-root" /lib/systemd/system/skrobot.service \
      > "$tmp/verify.log" 2>&1 || rc=$?
    [[ $rc -eq 0 && ! -s $tmp/verify.log ]] || { cat "$tmp/verify.log"; fail "systemd-analyze verify"; }
  else
    echo "   (no systemd-analyze here: the unit's lines were checked)"
  fi
  if [[ $(id -u) -eq 0 ]]; then ns=(unshare --mount --net); else ns=(unshare --map-root-user --mount --net); fi
  exec "${ns[@]}" env INSIDE_NAMESPACE=1 TMP="$tmp" LIBDIR="$lib" bash "$0" "$@"
fi

# --- inside the namespace: the unpacked packages alone ----------------------------------------
tmp=$TMP
# The trees first: they may lie under /tmp, which is hidden next.
[[ -d $build ]] && mount -t tmpfs tmpfs "$build"
for d in "$src" /tmp /run /var/lib; do mount -t tmpfs tmpfs "$d"; done
ip link set lo up
mkdir -p /run/skrobot /var/lib/skrobot "$tmp/home" "$tmp/cwd"
cd "$tmp/cwd"
root=$tmp/root
# A clean environment; an array, not a function, so that `"${run[@]}" prog &` is prog's own PID.
run=(env -i PATH=/usr/bin:/bin HOME="$tmp/home")
config=$root/etc/skrobot/skrobot.json

echo "== --list-modules from the unpacked root"
"${run[@]}" "$root/usr/bin/skrobot" --list-modules > "$tmp/list.log" 2>&1 || { cat "$tmp/list.log"; fail "--list-modules"; }
for m in "${expected_modules[@]}"; do
  grep -q "$root$LIBDIR/skrobot/modules/$m.so" "$tmp/list.log" || { cat "$tmp/list.log"; fail "$m not listed"; }
done

echo "== an account, made as the docs say, in the service's users file"
printf 'secret-1\n' | "${run[@]}" "$root/usr/bin/skrobot" user add tester --config "$config" --password-stdin \
  > "$tmp/user.log" 2>&1 || { cat "$tmp/user.log"; fail "skrobot user add"; }
[[ -f /var/lib/skrobot/users.json ]] || { cat "$tmp/user.log"; fail "no /var/lib/skrobot/users.json"; }

echo "== the hub with the packaged config"
"${run[@]}" "$root/usr/bin/skrobot" --config "$config" > "$tmp/hub.log" 2>&1 &
hub=$!
for _ in $(seq 600); do grep -q HUB-READY "$tmp/hub.log" && break; sleep 0.1; done
grep -q HUB-READY "$tmp/hub.log" || fail "no HUB-READY"
if grep -q FLOW-DEV-ACCOUNT "$tmp/hub.log"; then fail "the development account is on"; fi
[[ $(stat -c %a /run/skrobot/Robot) == 660 ]] || fail "socket mode $(stat -c %a /run/skrobot/Robot)"
export_addr=(--address local:/run/skrobot/Robot)
"${run[@]}" "$root/usr/bin/flowctl" "${export_addr[@]}" --user tester --password secret-1 ls > "$tmp/ls.log" 2>&1 ||
  { cat "$tmp/ls.log"; fail "flowctl ls as tester"; }
grep -q websocket-ui.camera "$tmp/ls.log" || { cat "$tmp/ls.log"; fail "no websocket-ui.camera"; }
rc=0; "${run[@]}" "$root/usr/bin/flowctl" "${export_addr[@]}" --user guest --password password ls > /dev/null 2>&1 || rc=$?
[[ $rc -eq 4 ]] || fail "guest/password was not refused (exit $rc)"
curl -sf http://127.0.0.1:8080/ | grep -qi "<html" || fail "no avatar page"

echo "== the packaged PySketch"
"${run[@]}" ROBOT_ADDRESS=local:/run/skrobot/Robot "$root/usr/bin/pysketch-executor" \
  "$tmp/publisher.py" --user tester --password secret-1 > "$tmp/sketch.log" 2>&1 &
sketch=$!
"${run[@]}" "$root/usr/bin/flowctl" "${export_addr[@]}" --user tester --password secret-1 \
  echo tester.sine --wait --count 2 --format hex > "$tmp/echo.log" 2>&1 ||
  { cat "$tmp/echo.log" "$tmp/sketch.log"; fail "no data from the packaged PySketch"; }
kill "$sketch"; wait "$sketch" 2>/dev/null || true

kill -TERM "$hub"
rc=0; wait "$hub" || rc=$?
[[ $rc -eq 0 ]] || fail "the hub exited with $rc"
echo "== ok"
