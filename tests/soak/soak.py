#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Soak: a hub under churning satellites, restarted a few times (issue 14, "Soak and faults").

Satellites, half C++ (soak_satellite) and half Python (py_satellite.py), publish, subscribe,
serve and call services and write a database; at random they are killed with SIGKILL or
stopped, and replaced. The hub is stopped cleanly and started again twice. Checked:

- the hub exits 0 each time, and AddressSanitizer and LeakSanitizer report nothing;
- its resident memory stays within 20% of its value after warm-up, in each run of the hub;
- its open file descriptors (the database logs it keeps open aside) come back to their count at
  start once the satellites are gone;
- every satellite that survives a restart reconnects and resubscribes by itself: each
  subscriber gets data again, each caller answers, each writer writes (the time is reported);
- every database write a satellite saw acknowledged is there at the end.

Environment: SKROBOT_BIN (the hub), SOAK_SATELLITE_BIN (soak_satellite), PYTHONPATH (PySketch),
SOAK_MINUTES (default 2), SOAK_SATELLITES (default 50).
"""
import atexit
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

from soakhub import Hub, waitUntil

HERE = os.path.dirname(os.path.abspath(__file__))
MINUTES = float(os.environ.get("SOAK_MINUTES", "2"))
SATELLITES = int(os.environ.get("SOAK_SATELLITES", "50"))
RECOVERY_LIMIT = 60.0  # seconds a surviving satellite may take to work again after a restart
RSS_GROWTH_LIMIT = 1.20
failures = []


def fail(why):
    failures.append(why)
    print("SOAK FAILURE: " + why, flush=True)


class Satellite(object):
    def __init__(self, hub, lang, role, name, target=None, anchor=False):
        self.lang, self.role, self.name, self.target, self.anchor = lang, role, name, target, anchor
        if lang == "cpp":
            cmd = [os.environ["SOAK_SATELLITE_BIN"], role, name]
        else:
            cmd = [sys.executable, os.path.join(HERE, "py_satellite.py"), role, name]
        if target:
            cmd.append(target)
        env = dict(os.environ, ROBOT_ADDRESS=hub.address, ROBOT_USER="guest",
                   ROBOT_PASSWORD="password")
        env["ASAN_OPTIONS"] = "detect_leaks=0:" + env.get("ASAN_OPTIONS", "")
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                     env=env)
        atexit.register(self.kill)
        self.events = 0           # DATA, RESP or ACK lines
        self.last_event = None    # time.monotonic() of the last one
        self.acked = []           # (key, value)
        self.mark = None          # the driver's "since": the time of the first event after it
        self.recovered_at = None
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        for raw in self.proc.stdout:
            line = raw.decode("utf-8", "replace").split()
            if not line:
                continue
            if line[0] in ("DATA", "RESP", "ACK"):
                self.events += 1
                self.last_event = time.monotonic()
                if self.mark is not None and self.recovered_at is None:
                    self.recovered_at = self.last_event
                if line[0] == "ACK" and len(line) == 3:
                    self.acked.append((line[1], int(line[2])))

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def alive(self):
        return self.proc.poll() is None

    def end(self, how):
        if self.alive():
            self.proc.send_signal(how)
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.thread.join(5)


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(p / 100.0 * (len(values) - 1))))]


def main():
    random.seed(os.getpid())
    workdir = tempfile.mkdtemp(prefix="skrobot-soak-")
    hub = Hub(workdir, "soak", fail)
    hub.start()
    time.sleep(1.0)
    base_fds = hub.fds()  # before anybody connects, once the start has settled
    # The database the writers write, created once; it survives the restarts.
    from PySketch.flowsync import FlowSync
    with FlowSync(hub.address, "guest", "password", "soak-driver") as sync:
        if not sync.connect() or not sync.createDatabase("soak"):
            raise SystemExit("cannot create the soak database")

    counter = [0]

    def newName(role):
        counter[0] += 1
        return "%s%d" % (role, counter[0])

    # Anchors are never killed: the channels and services that survivors come back to.
    sats = [Satellite(hub, "cpp", "pub", "anchor_c", anchor=True),
            Satellite(hub, "py", "pub", "anchor_p", anchor=True),
            Satellite(hub, "cpp", "svc", "svc_c", anchor=True),
            Satellite(hub, "py", "svc", "svc_p", anchor=True)]
    roles = ["sub", "call", "db", "pub", "sub"]
    targets = {"sub": ["guest.anchor_c", "guest.anchor_p"], "call": ["guest.svc_c", "guest.svc_p"]}

    def spawn(i):
        role = roles[i % len(roles)]
        lang = "cpp" if i % 2 == 0 else "py"
        name = newName(role)
        target = random.choice(targets[role]) if role in targets else None
        if role == "db":
            # Slot i's keys, values above every earlier writer's of the slot.
            target = "w%d:%d" % (i, counter[0] * 1000000)
        return Satellite(hub, lang, role, name, target)

    # spawn(i) makes the satellite of sats[i]: its role, and for a writer its keys, stay with i.
    for i in range(len(sats), max(len(sats), SATELLITES)):
        sats.append(spawn(i))
    print("soak: %d satellites (%d C++, %d Python), %.1f minutes" % (
        len(sats), sum(s.lang == "cpp" for s in sats), sum(s.lang == "py" for s in sats),
        MINUTES), flush=True)

    duration = MINUTES * 60.0
    start = time.monotonic()
    restarts_at = [start + duration * 0.35, start + duration * 0.7]
    # Memory is compared from a third into each run of the hub (a run lasts a third of it all).
    warmup = min(30.0, duration * 0.35 * 0.3)
    rss_base, rss_max, kills, stops, spawned = None, 0, 0, 0, 0
    recoveries = []
    retired = []

    def measureRss():
        nonlocal rss_base, rss_max
        now = time.monotonic()
        if now - hub.started < warmup:
            return
        rss = hub.rssKiB()
        if rss_base is None:
            rss_base = rss
        rss_max = max(rss_max, rss)

    def checkRss():
        if rss_base is not None and rss_max > rss_base * RSS_GROWTH_LIMIT:
            fail("run %d: resident memory grew from %d KiB after warm-up to %d KiB (> %d%%)" % (
                hub.runs, rss_base, rss_max, int((RSS_GROWTH_LIMIT - 1) * 100)))
        print("soak: run %d: RSS %s KiB after warm-up, at most %d KiB" % (
            hub.runs, rss_base, rss_max), flush=True)

    next_churn = start + 1.0
    while time.monotonic() - start < duration:
        time.sleep(0.1)
        measureRss()
        now = time.monotonic()
        if restarts_at and now >= restarts_at[0]:
            restarts_at.pop(0)
            checkRss()
            hub.stop()
            time.sleep(1.0)  # everybody notices, and their last lines are read
            for s in sats:
                s.mark, s.recovered_at = None, None
            hub.start()
            rss_base, rss_max = None, 0
            back = hub.started
            # Each survivor works again by itself: data, answers, acknowledged writes.
            waiting = [s for s in sats if s.alive() and s.role in ("sub", "call", "db")]
            for s in waiting:
                s.mark = back
            waitUntil(lambda: all(s.recovered_at is not None for s in waiting if s.alive()),
                      RECOVERY_LIMIT)
            for s in waiting:
                if not s.alive():
                    continue
                if s.recovered_at is None:
                    fail("run %d: %s satellite %s (%s) did not work again within %d s of the "
                         "restart" % (hub.runs, s.lang, s.name, s.role, RECOVERY_LIMIT))
                else:
                    recoveries.append(s.recovered_at - back)
            next_churn = time.monotonic() + 1.0
            continue
        if now >= next_churn:
            next_churn = now + 0.5
            victims = [i for i, s in enumerate(sats) if not s.anchor]
            i = random.choice(victims)
            how = signal.SIGKILL if random.random() < 0.6 else signal.SIGTERM
            sats[i].end(how)
            kills += how == signal.SIGKILL
            stops += how == signal.SIGTERM
            retired.append(sats[i])
            sats[i] = spawn(i)
            spawned += 1
    checkRss()

    # The satellites go; the hub's descriptors come back to their count at start.
    for s in sats:
        s.end(signal.SIGKILL)
    retired.extend(sats)
    fds_ok = waitUntil(lambda: hub.fds()[0] == base_fds[0], 20, 0.2)
    other, logs, kinds = hub.fds()
    if not fds_ok:
        fail("the hub holds %d descriptors with no satellite left, %d at start (database logs "
             "aside: %d): now %s, at start %s" % (other, base_fds[0], logs, kinds, base_fds[2]))
    print("soak: descriptors %d at start, %d at the end (and %d database logs)" % (
        base_fds[0], other, logs), flush=True)

    # Every acknowledged write is there after the restarts and a last one.
    hub.stop()
    hub.start()
    with FlowSync(hub.address, "guest", "password", "soak-driver") as sync:
        if not sync.connect() or not sync.setCurrentDbName("soak"):
            fail("cannot read the soak database at the end")
        pairs = sync.getAllVariables() or {}
    # A key holds its last acknowledged value, or a later one (a write whose answer was lost).
    acked = [a for s in retired for a in s.acked]
    newest = {}
    for k, v in acked:
        newest[k] = max(v, newest.get(k, v))
    lost = [(k, v, pairs.get(k)) for k, v in sorted(newest.items())
            if not isinstance(pairs.get(k), int) or pairs.get(k) < v]
    if lost:
        fail("%d of %d keys lost their last acknowledged write, e.g. (key, acknowledged, found) "
             "%s" % (len(lost), len(newest), lost[:5]))
    hub.stop()

    print("soak: %d satellites started in all (%d killed with SIGKILL, %d stopped), %d hub "
          "runs, %d acknowledged writes to %d keys, all kept" % (
              len(retired), kills, stops, hub.runs, len(acked), len(newest)), flush=True)
    if recoveries:
        print("soak: recovery after a restart (hub ready -> working again), %d satellites: "
              "p50 %.2f s, p90 %.2f s, max %.2f s" % (
                  len(recoveries), percentile(recoveries, 50), percentile(recoveries, 90),
                  max(recoveries)), flush=True)
    if failures:
        print("soak: %d failure(s); hub logs in %s" % (len(failures), workdir), flush=True)
        return 1
    shutil.rmtree(workdir, ignore_errors=True)
    print("soak: passed", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
