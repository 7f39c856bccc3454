# SPDX-License-Identifier: Apache-2.0
"""The sync pulse from PySketch (FlowSat.addSyncSource, pulse, followSync) against a real hub,
under Python 3 and 2.7. The follower runs its loop on a thread of its own, as a sketch would."""
import threading
import time

from tests.hubtest import HubTestCase, pump, waitUntil


class Follower(object):
    """A FlowSat's loop on a thread: tick(), then a loop() that takes `work` seconds."""

    def __init__(self, sat, work=0.0):
        self.sat = sat
        self.work = work
        self.loops = 0
        self.pulses = []   # (seq, dropped) from the sync callback
        self.lost = 0
        self._stop = threading.Event()
        sat.setSyncCallBack(lambda chan, seq, dropped: self.pulses.append((seq, dropped)))
        sat.setSyncLostCallBack(lambda chan: self._lost())
        self._thread = threading.Thread(target=self._run)
        self._thread.daemon = True
        self._thread.start()

    def _lost(self):
        self.lost += 1

    def _run(self):
        while not self._stop.is_set():
            self.sat.tick()
            self.loops += 1
            if self.work:
                time.sleep(self.work)

    def stop(self, release=None):
        """Ends the loop; `release()` (a pulse) wakes a tick() that waits for pulses."""
        self._stop.set()
        for _ in range(200):
            if release is not None:
                release()
            self._thread.join(0.05)
            if not self._thread.is_alive():
                return


class SyncPulse(HubTestCase):
    def source(self):
        src = self.connected()
        self.assertTrue(src.addSyncSource("clock"))
        self.assertTrue(pump([src], lambda: src.channelByName("guest.clock") is not None))
        return src

    def pulseUntil(self, src, cond, period=0.01, limit=10.0):
        """Pulses every `period` seconds until cond() (False after `limit` seconds)."""
        end = time.time() + limit
        while time.time() < end:
            src.pulse("guest.clock")
            src.tick()
            time.sleep(period)
            if cond():
                return True
        return cond()

    def follower(self, src, every=1, timeout=None, strict=False, work=0.0):
        f = self.connected(tick=0.05)
        self.assertTrue(f.followSync("guest.clock", every=every, timeout=timeout, strict=strict))
        runner = Follower(f, work)

        def release():
            src.pulse("guest.clock")
            src.tick()
        self.addCleanup(lambda: runner.stop(release))
        return runner

    def test_tick_returns_on_each_pulse_in_order(self):
        src = self.source()
        f = self.follower(src)
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= 1))
        time.sleep(0.1)  # what was sent before the first pulse arrived has settled
        base = len(f.pulses)
        # One pulse at a time, each once the follower's loop is past the one before (its next
        # tick() sends SYNC_DONE): the hub then has no reason to drop any, however slow it runs.
        for _ in range(30):
            n, loops = len(f.pulses), f.loops
            src.pulse("guest.clock")
            src.tick()
            self.assertTrue(waitUntil(lambda: len(f.pulses) > n and f.loops > loops))
            time.sleep(0.02)
        got = f.pulses[base:]
        seqs = [s for s, _ in got]
        self.assertEqual(seqs, list(range(seqs[0], seqs[0] + 30)), "in order, none lost")
        self.assertEqual(sum(d for _, d in got), 0)
        # The loop ran once per pulse: the 50 ms own timer would give a handful in this time.
        self.assertGreaterEqual(f.loops, len(f.pulses) - 1)
        self.assertEqual(f.lost, 0)
        self.assertEqual(f.sat.lastPulse[1], seqs[-1])

    def test_every_second_pulse(self):
        src = self.source()
        f = self.follower(src, every=2)
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= 10))
        seqs = [s for s, _ in f.pulses]
        self.assertTrue(all(b - a == 2 for a, b in zip(seqs, seqs[1:])), seqs)

    def test_a_slow_loop_gets_pulses_dropped_and_counted(self):
        src = self.source()
        f = self.follower(src, work=0.05)  # its loop() takes 50 ms; pulses come every 10 ms
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= 8))
        self.assertGreater(f.sat.syncDropped, 0)
        self.assertEqual(f.sat.syncDropped, sum(d for _, d in f.pulses))

    def test_without_pulses_the_own_timer_takes_over_then_pulses_again(self):
        src = self.source()
        f = self.follower(src, timeout=0.3)
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= 5))
        loops = f.loops
        time.sleep(1.2)  # no pulse: after 0.3 s the 50 ms timer ticks
        self.assertEqual(f.lost, 1)
        self.assertGreaterEqual(f.loops - loops, 5, "the own timer did not take over")
        count = len(f.pulses)
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= count + 5))

    def test_strict_waits_for_pulses(self):
        src = self.source()
        f = self.follower(src, timeout=0.3, strict=True)
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= 5))
        time.sleep(0.2)
        loops = f.loops
        time.sleep(1.0)
        self.assertEqual(f.lost, 1)
        self.assertEqual(f.loops, loops, "strict: no tick without pulses")

    def test_unfollow_stops_the_pulses(self):
        src = self.source()
        f = self.follower(src)
        self.assertTrue(self.pulseUntil(src, lambda: len(f.pulses) >= 3))
        f.stop(lambda: (src.pulse("guest.clock"), src.tick()))
        f.sat.unfollowSync("guest.clock")
        f.sat.tick()
        count = len(f.pulses)
        for _ in range(10):
            src.pulse("guest.clock")
            src.tick()
            f.sat.tick()
        self.assertEqual(len(f.pulses), count)

    def test_the_tick_mode_is_in_the_flow_database(self):
        from PySketch.flowsync import FlowSync
        self.source()
        sat = self.connected(tick=0.05)
        switches = []
        sat.setDbChangedCallBack(lambda name: switches.append(name))
        reader = FlowSync(self.hub.address, "guest", "password")
        self.addCleanup(reader.close)
        self.assertTrue(reader.connect())
        self.assertTrue(reader.setCurrentDbName("_flow.%d" % sat.connectionID))

        def mode():
            return (reader.getVariable("tick_mode"), reader.getVariable("tick_interval_ms"))
        self.assertTrue(pump([sat], lambda: mode() == ("timer", 50.0)), mode())
        sat.followSync("guest.clock", timeout=0.1)  # no pulses: tick() returns after 0.1 s
        self.assertTrue(pump([sat], lambda: mode()[0] == "sync"), mode())
        sat.unfollowSync("guest.clock")
        sat.setTickTimer(0.02)
        self.assertTrue(pump([sat], lambda: mode() == ("timer", 20.0)), mode())
        self.assertEqual(switches, [], "the library's own database switches reached the callback")
        self.assertEqual(sat.currentDbName, "guest")

