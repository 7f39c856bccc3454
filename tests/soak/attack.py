#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Attack: the hub stays responsive to a well-behaved satellite while others misbehave (issue 14).

A well-behaved satellite (PySketch's FlowSync, logged in before anything starts) sends PING after
PING and records each round trip. Meanwhile, one after the other:

- login flood: connections that log in with wrong passwords, as fast as they are refused;
- slow frames: hundreds of connections that send three bytes of a frame and nothing more;
- huge lengths: frames announcing 2 GiB before login and 1 GiB after it;
- channel flood: four logged-in flows that each ask for 5000 channels in batches of a hundred
  (the per-user limit refuses most), the hub handling a budget of each one's frames per turn.

Checked: every ping is answered (no error, no timeout) and the p99 of each phase stays under
ATTACK_P99_MS (500 ms by default, what the AddressSanitizer build is held to; the release build's
test asks for 100 ms); each misbehaving connection is closed or refused as docs/security.md
says; the hub exits 0 with no sanitizer report. The round trips of each phase are printed beside
the calm baseline.

Environment: SKROBOT_BIN, PYTHONPATH (PySketch), ATTACK_SECONDS (per phase, default 5),
ATTACK_P99_MS (default 500).
"""
import os
import shutil
import socket
import struct
import sys
import tempfile
import threading
import time

from PySketch.flowproto import encodeValue, frame, str16, u8, u32
from PySketch.flowsync import FlowSync
from soakhub import Hub

PHASE_SECONDS = float(os.environ.get("ATTACK_SECONDS", "5"))
P99_LIMIT = float(os.environ.get("ATTACK_P99_MS", "500")) / 1000.0
failures = []


def fail(why):
    failures.append(why)
    print("ATTACK FAILURE: " + why, flush=True)


LOGIN, GO_ASYNC, CHAN_ADD = 0x01, 0x0F, 0x40


def loginFrame(user, password):
    return frame(LOGIN, struct.pack("<HHB", 1, 2, 0) + str16(user) + str16(password) +
                 str16("attacker"))


def dial(path):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(10)
    s.connect(path)
    return s


def closedByHub(s, timeout=10.0):
    """True once the hub closed `s` (EOF or reset), reading and discarding whatever came first."""
    s.settimeout(timeout)
    deadline = time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            if not s.recv(65536):
                return True
    except (ConnectionResetError, BrokenPipeError):
        return True
    except socket.timeout:
        return False
    return False


class Pinger(threading.Thread):
    """The well-behaved satellite: PING after PING, each round trip filed under the phase."""

    def __init__(self, address):
        threading.Thread.__init__(self, daemon=True)
        self.sync = FlowSync(address, "guest", "password", "well-behaved", timeout=5.0)
        if not self.sync.connect():
            raise SystemExit("the well-behaved satellite cannot log in")
        self.phase = "calm"
        self.rtts = {}
        self.errors = 0
        self.running = True

    def run(self):
        while self.running:
            rtt = self.sync.ping(b"x" * 16)
            if rtt is None:
                self.errors += 1
                fail("phase %s: a ping failed (%s)" % (self.phase, self.sync.lastError))
                if not self.sync.connect():
                    time.sleep(0.1)
                continue
            self.rtts.setdefault(self.phase, []).append(rtt)
            time.sleep(0.002)


def during(pinger, name, attack, threads=4):
    """Runs `attack(stop_event)` in `threads` threads for PHASE_SECONDS while the pinger files
    under `name`."""
    stop = threading.Event()
    pinger.phase = name
    threads = [threading.Thread(target=attack, args=(stop,), daemon=True) for _ in range(threads)]
    for t in threads:
        t.start()
    time.sleep(PHASE_SECONDS)
    stop.set()
    for t in threads:
        t.join(30)
    pinger.phase = "calm-after-" + name


def main():
    workdir = tempfile.mkdtemp(prefix="skrobot-attack-")
    # The defaults that matter here: 5 s to log in, 4096 bytes before login, 16 MiB after,
    # 1024 connections, 1024 channels per user.
    hub = Hub(workdir, "attack", fail, server={})
    hub.start()
    path = hub.address[len("local:"):]
    pinger = Pinger(hub.address)
    pinger.start()
    time.sleep(PHASE_SECONDS)
    counts = {}

    def loginFlood(stop):
        while not stop.is_set():
            try:
                s = dial(path)
                s.sendall(loginFrame("guest", "wrong-password"))
                closedByHub(s, 10)
                s.close()
                counts["refused logins"] = counts.get("refused logins", 0) + 1
            except OSError:
                time.sleep(0.01)

    during(pinger, "login-flood", loginFlood)

    held = []

    def slowFrames(stop):
        mine = []
        while not stop.is_set() and len(mine) < 150:
            try:
                s = dial(path)
                s.sendall(b"\x40\x00\x00")  # 3 of a frame header's 5 bytes, never the rest
                mine.append(s)
            except OSError:
                time.sleep(0.01)
        held.extend(mine)
        stop.wait()

    during(pinger, "slow-frames", slowFrames)
    # Closed by the login timeout (5 s), while the well-behaved one went on.
    closed = sum(1 for s in held if closedByHub(s, 10))
    counts["slow connections closed by the login timeout"] = closed
    if closed != len(held):
        fail("%d of %d connections that never finished a frame were not closed" % (
            len(held) - closed, len(held)))
    for s in held:
        s.close()

    def hugeLengths(stop):
        while not stop.is_set():
            try:
                s = dial(path)
                s.sendall(struct.pack("<IB", 2 << 30, LOGIN))  # 2 GiB before login
                if not closedByHub(s, 5):
                    fail("a 2 GiB frame before login did not close the connection")
                s.close()
                s = dial(path)
                s.sendall(loginFrame("guest", "password"))
                s.recv(4096)  # the LOGIN reply
                s.sendall(struct.pack("<IB", 1 << 30, 0x07))  # 1 GiB VAR_SET after login
                if not closedByHub(s, 5):
                    fail("a 1 GiB frame after login did not close the connection")
                s.close()
                counts["huge frames refused"] = counts.get("huge frames refused", 0) + 2
            except OSError:
                time.sleep(0.01)

    during(pinger, "huge-lengths", hugeLengths)

    def channelFlood(stop):
        try:
            s = dial(path)
            s.sendall(loginFrame("guest", "password"))
            s.recv(4096)
            s.sendall(frame(GO_ASYNC))
            s.recv(4096)
            s.settimeout(0.2)  # what came back is drained, then the next hundred asked
            n = 0
            while not stop.is_set() and n < 5000:
                batch = b"".join(frame(CHAN_ADD, u32(n + i) + u8(1) + str16("flood%d_%d" % (
                    id(s) % 1000, n + i)) + str16("") + encodeValue(None)) for i in range(100))
                s.sendall(batch)
                n += 100
                try:
                    while s.recv(1 << 20):
                        pass
                except socket.timeout:
                    pass
            counts["channels asked for"] = counts.get("channels asked for", 0) + n
            stop.wait()
            s.close()
        except OSError as e:
            fail("channel flood: %s" % e)

    during(pinger, "channel-flood", channelFlood, threads=4)
    time.sleep(1.0)
    pinger.running = False
    pinger.join(10)
    pinger.sync.close()
    hub.stop()
    log = hub.log()
    for tag in ("FLOW-AUTH-FAILED", "FLOW-LOGIN-THROTTLED", "FLOW-LIMIT", "FLOW-PROTOCOL"):
        if tag not in log:
            fail("the hub never logged %s" % tag)

    print("attack: %s" % ", ".join("%s %d" % kv for kv in sorted(counts.items())), flush=True)
    print("%-26s %8s %9s %9s %9s" % ("phase", "pings", "p50 ms", "p99 ms", "max ms"), flush=True)
    for phase in ["calm", "login-flood", "slow-frames", "huge-lengths", "channel-flood"]:
        rtts = sorted(pinger.rtts.get(phase, []))
        if not rtts:
            fail("phase %s: no ping answered" % phase)
            continue
        p50 = rtts[len(rtts) // 2]
        p99 = rtts[min(len(rtts) - 1, int(len(rtts) * 0.99))]
        print("%-26s %8d %9.3f %9.3f %9.3f" % (phase, len(rtts), p50 * 1e3, p99 * 1e3,
                                               rtts[-1] * 1e3), flush=True)
        if p99 > P99_LIMIT:
            fail("phase %s: the p99 round trip is %.3f s (> %.1f s)" % (phase, p99, P99_LIMIT))
    if failures:
        print("attack: %d failure(s); hub logs in %s" % (len(failures), workdir), flush=True)
        return 1
    shutil.rmtree(workdir, ignore_errors=True)
    print("attack: passed", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
