# SPDX-License-Identifier: Apache-2.0
"""Physical mode as a PySketch subscriber (PySketch/flowpaths.py, docs/physical-mode.md).

Against a real hub and a C++ owner (satellite/cpp/tests/paths_publisher, given as
$SKROBOT_PATHS_PUBLISHER, else looked for next to $SKROBOT_BIN): shared-memory delivery with its
content checked in place (memoryview, numpy), a direct path in order, fallback without
duplicates when the path breaks mid-stream, a slow reader (newest wins, missed counted), an
owner killed while its reader reads, a path that cannot be had, a hub that speaks 1.6, and
subscribers that switch to their paths while the owner publishes without pause (nothing lost), a
slot held by its reader while the owner wraps the ring (the lease), and an owner that counts
instead of publishing once nobody is relayed (PHYS_COUNT). test_paths_owner.py runs PathsWithAHub
again with a PySketch owner (OWNER).
Without a hub: the ring reader against rings made here (refused, torn, out of bounds) and a fake
owner that breaks the path framing, and the marker rules (EV_PHYS_MARKER's number, the old
EV_PHYS_RELAY 0, a switch cancelled by a break, the read-ahead before the marker).

Under Python 2.7 (run_py27.sh) only PathsUnderPython2 runs: usePaths is accepted and the channel
stays relayed. Nothing here depends on speed: every wait has a generous timeout.
"""
import os
import signal
import socket
import struct
import sys
import tempfile
import threading
import time
import unittest

from PySketch.flowproto import PATH_DIRECT, PATH_SHM
from tests.compat import PY2, monotonic
from tests.hubtest import TIMEOUT, HubTestCase, Sketch, pump, tickFor, waitUntil

PATHS = not PY2 and hasattr(socket.socket, "recvmsg") and hasattr(os, "memfd_create")
LONG = 30.0  # a path asked again after its backoff (1 s, 2 s, 4 s) on a loaded machine


def publisherBin():
    path = os.environ.get("SKROBOT_PATHS_PUBLISHER")
    if not path and os.environ.get("SKROBOT_BIN"):
        path = os.path.join(os.path.dirname(os.environ["SKROBOT_BIN"]), "paths_publisher")
    if not path or not os.path.exists(path):
        raise unittest.SkipTest("no paths_publisher (set SKROBOT_PATHS_PUBLISHER)")
    return path


def number(payload):
    """The message number paths_publisher wrote, after checking its pattern."""
    b = bytearray(payload)
    n = struct.unpack_from("<Q", bytes(b[:8]))[0]
    for i in range(8, len(b)):
        if b[i] != (n + i) & 0xFF:
            raise AssertionError("message %d: byte %d is %d, not %d" % (n, i, b[i], (n + i) & 0xFF))
    return n


class Commanded(Sketch):
    """A test program driven by commands on its stdin, one a line; "quit" ends it."""

    def close(self):
        if self.proc.poll() is None:
            try:
                self.send("quit")
            except (IOError, OSError):
                pass
            if not waitUntil(lambda: self.proc.poll() is not None, TIMEOUT):
                self.proc.kill()
        self.proc.wait()
        self.reader.join(TIMEOUT)
        for f in (self.proc.stdin, self.proc.stdout):
            try:
                f.close()
            except (IOError, OSError):
                pass


class Publisher(Commanded):
    """paths_publisher as a subprocess, driven by commands on its stdin."""

    def __init__(self, hub, kinds, slot=65536, channel="frames", rate=None, command=None):
        """rate: its loop's frequency (Hz; 200 by default), that of `slow`; command: the owner
        to run (default: the C++ paths_publisher; PYTHON_OWNER: its PySketch twin)."""
        Sketch.__init__(self, (command or [publisherBin()]) +
                        [hub.address, channel, kinds, str(slot)] +
                        ([str(rate)] if rate else []), env=None, stdin=True)

    def count(self, pattern):
        return len(self.matching(pattern))

    def do(self, command, answer, sats=(), timeout=TIMEOUT):
        """Sends a command and waits for its answer, ticking `sats` meanwhile."""
        before = self.count(answer)
        self.send(command)
        ok = pump(sats, lambda: self.count(answer) > before, timeout) if sats else \
            waitUntil(lambda: self.count(answer) > before, timeout)
        if not ok:
            raise AssertionError("no %r after %r:\n%s" % (answer, command, self.output()))

    def kill(self, sig=signal.SIGKILL):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        self.proc.wait()



# The PySketch owner (tests/paths_publisher.py, PySketch/flowowner.py), for PathsWithAHub's
# subclass in test_paths_owner.py.
PYTHON_OWNER = [sys.executable, "-m", "tests.paths_publisher"]


@unittest.skipUnless(PATHS, "paths need Python 3 (recvmsg, memfd)")
class PathsWithAHub(HubTestCase):
    OWNER = None  # the channel owner's command (None: the C++ paths_publisher)

    def publisher(self, kinds, slot=65536, rate=None):
        p = Publisher(self.hub, kinds, slot, rate=rate, command=self.OWNER)
        self.addCleanup(p.close)
        if not waitUntil(lambda: p.count("^ready ") > 0, TIMEOUT):
            raise AssertionError("paths_publisher not ready:\n" + p.output())
        return p

    def subscriber(self, kinds, pathsFirst=True):
        s = self.connected()
        s.got = []
        s.setGrabDataCallBack(lambda chan, data: s.got.append(number(data)))
        if pathsFirst:
            s.usePaths("guest.frames", kinds)
        s.subscribeChannel("guest.frames")
        if not pathsFirst:
            self.assertTrue(pump([s], lambda: s.channelByName("guest.frames") is not None and
                                 s.channelByName("guest.frames").isSubscribed))
            s.usePaths("guest.frames", kinds)
        return s

    def onPath(self, pub, s, timeout=LONG):
        """Publishes until a message comes by the path (the marker came)."""
        deadline = monotonic() + timeout
        while monotonic() < deadline:
            pub.do("pub 1 64", "^published", [s])
            tickFor([s], 0.05)
            if s.pathStats()["path_messages"] > 0:
                return
        raise AssertionError("no path in %.0f s: %r\n%s" % (timeout, s.pathStats(), pub.output()))

    def test_shared_memory_delivers_in_place(self):
        pub = self.publisher("shm")
        s = self.subscriber(PATH_SHM)
        self.onPath(pub, s)
        seen = []

        def onView(chan, view):
            self.assertTrue(view.readonly)
            seen.append((number(view), len(view), view.nbytes))
            arr = None
            try:
                from PySketch.flowpaths import ringArray
                arr = ringArray(view)
            except ImportError:
                pass
            if arr is not None:
                n = seen[-1][0]
                self.assertFalse(arr.flags.writeable)
                self.assertEqual(int(arr[100]), (n + 100) & 0xFF)
                self.assertEqual(len(arr), len(view))
        s.setGrabDataViewCallBack(onView)
        before = s.pathStats()["path_messages"]
        s.got = []
        # Filled in the slot in place by the owner, read in place here.
        pub.do("zc 1 40000", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in s.got), (s.got, s.pathStats()))
        tickFor([s], 0.3)
        self.assertEqual(s.got, [last], "once: not relayed as well")
        self.assertEqual(seen[-1], (last, 40000, 40000))
        st = s.pathStats()
        self.assertEqual(st["path_messages"], before + 1, "it came by the path, not the hub")
        self.assertEqual(st["torn"], 0)
        # One at a time, each waited for: every one by the path, none missed.
        for _ in range(30):
            pub.do("pub 1 1000", "^published", [s])
            last = int(pub.last().split()[1])
            self.assertTrue(pump([s], lambda: last in s.got))
        st = s.pathStats()
        self.assertEqual(st["path_messages"], before + 31)
        self.assertEqual((st["torn"], st["fallbacks"], st["missed"]), (0, 0, 0))
        self.assertEqual(s.got, sorted(set(s.got)))

    def test_direct_path_in_order(self):
        pub = self.publisher("direct")
        s = self.subscriber(PATH_DIRECT | PATH_SHM, pathsFirst=False)  # the owner: direct only
        self.onPath(pub, s)
        before = s.pathStats()["path_messages"]
        s.got = []
        holders = set()  # what the view callback's views are of: the path's input, in place
        s.setGrabDataViewCallBack(lambda chan, view: holders.add(type(view.obj)))
        pub.do("pub 300 3000", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in s.got), (len(s.got), s.pathStats()))
        self.assertEqual(s.got, list(range(last - 299, last + 1)), "all, in order, once")
        self.assertEqual(holders, {bytearray}, "views of the path's input, not of copies")
        self.assertEqual(s.pathStats()["path_messages"], before + 300)
        pub.do("stats", "^stats", [s])
        self.assertIn("served_direct=1", pub.last())

    @staticmethod
    def busyAfterPhysState(send, seconds):
        def sendThenWait(data):
            ok = send(data)
            if bytes(data[4:5]) == b"\xf2" and bytes(data[7:8]) == b"\x01":  # PHYS_STATE 1
                time.sleep(seconds)
            return ok
        return sendThenWait

    def test_switching_to_a_direct_path_loses_nothing(self):
        # The owner publishes without pause while subscribers switch to their paths, each at
        # another point of the stream: from its first message on, each gets every message once,
        # in order (EV_PHYS_MARKER; paths_test.cpp SwitchingToADirectPathLosesNothing).
        pub = self.publisher("direct", rate=1000)
        pub.send("slow 1000000000 64")   # a message per loop (1 kHz) until told otherwise
        subs = []
        for k in range(5):
            s = self.subscriber(PATH_DIRECT)
            subs.append(s)
            # Once its path is open (PHYS_STATE 1 sent) it is busy for a while, as a sketch may
            # be: the owner's messages after the switch wait on the path, the marker with them.
            s._send = self.busyAfterPhysState(s._send, 0.02 * k)
            tickFor(subs, 0.2)
        ok = pump(subs, lambda: all(s.pathStats()["path_messages"] > 100 for s in subs), LONG)
        self.assertTrue(ok, [s.pathStats() for s in subs])
        pub.send("slow 1 64")            # one more, then it stops and says which
        self.assertTrue(pump(subs, lambda: pub.count("^published") > 0), pub.output())
        last = int(pub.matching("^published")[-1].split()[1])
        self.assertTrue(pump(subs, lambda: all(last in s.got for s in subs)),
                        [(s.got[-3:], s.pathStats()) for s in subs])
        for k, s in enumerate(subs):
            got = s.got[:]
            self.assertEqual(got, list(range(got[0], last + 1)),
                             "subscriber %d: every message once, in order (%d of %d-%d)"
                             % (k, len(got), got[0], last))
            st = s.pathStats()
            self.assertEqual(st["fallbacks"], 0, (k, st))
            self.assertGreater(st["path_messages"], 100, (k, st))

    def fallback(self, kinds, kind):
        pub = self.publisher(kinds)
        s = self.subscriber(kind)
        self.onPath(pub, s)
        s.got = []
        first = int(pub.last().split()[1]) + 1
        # Numbered messages; the owner breaks every path in the middle: relayed again, asked
        # again after the backoff, by the path again.
        pub.do("pub 100 64", "^published", [s])
        tickFor([s], 0.05)
        pub.send("reset")   # and at once more messages, before the hub hears of the break
        for _ in range(10):
            pub.do("pub 20 64", "^published", [s])
            tickFor([s], 0.02)
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in s.got), (len(s.got), s.pathStats()))
        got = s.got[:]
        self.assertEqual(got, sorted(set(got)), "in order, none twice")
        self.assertTrue(set(got) <= set(range(first, last + 1)))
        if kind == PATH_DIRECT:
            # 1.11: the owner replays what the broken path lost (PHYS_FALLBACK).
            self.assertEqual(got, list(range(first, last + 1)), "nothing lost")
        st = s.pathStats()
        self.assertGreaterEqual(st["fallbacks"], 1)
        # Asked again: the path comes back.
        paths = st["path_messages"]
        ok = pump([s], lambda: (pub.do("pub 1 64", "^published", [s]) or True) and
                  s.pathStats()["path_messages"] > paths, LONG)
        self.assertTrue(ok, s.pathStats())
        self.assertEqual(s.got, sorted(set(s.got)), "in order, none twice")

    def test_fallback_without_loss_or_duplicates_direct(self):
        self.fallback("direct", PATH_DIRECT)

    def test_fallback_without_duplicates_shm(self):
        self.fallback("shm", PATH_SHM)

    def publishToASlowReader(self, pub, s, delay):
        """200 messages at once to `s`, whose callback takes `delay` s: until it has the last."""
        def slow(chan, data):
            s.got.append(number(data))
            time.sleep(delay)
        s.setGrabDataCallBack(slow)
        s.got = []
        pub.send("pub 200 64")   # all at once: the owner never waits for the reader
        self.assertTrue(pump([s], lambda: pub.count("^published") >= 2 and
                             int(pub.last().split()[1]) in s.got), (s.got, pub.output()))

    def test_slow_reader_gets_the_newest(self):
        pub = self.publisher("shm")
        s = self.subscriber(PATH_SHM)
        self.onPath(pub, s)

        before = s.pathStats()
        self.publishToASlowReader(pub, s, 0.02)
        last = int(pub.last().split()[1])
        got = s.got[:]
        self.assertEqual(got, sorted(set(got)))
        self.assertTrue(set(got) <= set(range(last - 199, last + 1)))
        self.assertLess(len(got), 200, "a busy reader skips to the newest")
        st = s.pathStats()
        self.assertGreaterEqual(st["missed"] - before["missed"], 200 - len(got))
        self.assertEqual((st["torn"], st["fallbacks"]), (0, 0))

    def test_a_slot_being_read_is_not_rewritten(self):
        """The owner publishes 200 messages at once while the reader holds its first slot for
        0.3 s: the lease keeps that slot as it was (no torn read, the same message after)."""
        pub = self.publisher("shm")
        s = self.subscriber(PATH_SHM)
        self.onPath(pub, s)
        held = []

        def hold(chan, view):
            if not held:
                first = number(view)
                pub.send("pub 200 64")
                time.sleep(0.3)   # the owner wraps its ring of 4 slots many times meanwhile
                held.append((first, number(view)))
        s.setGrabDataViewCallBack(hold)
        before = s.pathStats()
        pub.do("pub 1 64", "^published", [s])
        self.assertTrue(pump([s], lambda: held and pub.count("^published") >= 3), pub.output())
        tickFor([s], 0.2)
        self.assertEqual(held[0][0], held[0][1], "the slot was rewritten while it was read")
        self.assertEqual(s.pathStats()["torn"], before["torn"])

    def test_the_hub_counts_what_comes_on_the_path(self):
        """PHYS_RECEIVED (1.10): the hub's statistics of our flow include what came on the path
        (messages and bytes out, path_messages, path_bytes) and what we skipped (dropped)."""
        from PySketch.flowsync import FlowSync
        pub = self.publisher("shm")
        s = self.subscriber(PATH_SHM)
        self.onPath(pub, s)

        self.publishToASlowReader(pub, s, 0.005)
        stats = FlowSync(self.hub.address, "guest", "password")
        self.assertTrue(stats.connect())
        self.addCleanup(stats.close)

        def ours():
            for f in stats.serviceCall("hub.inspect", "stats")["flows"]:
                if f["client"] == s.clientName() and f["kind"] == "satellite":
                    return f
            return {}
        seen = [{}]

        def reported():
            seen[0] = ours()
            st = s.pathStats()
            return (seen[0].get("path_messages") == st["path_messages"] and
                    seen[0].get("dropped") == st["missed"])
        self.assertTrue(pump([s], reported), (seen[0], s.pathStats()))
        f = seen[0]
        self.assertGreater(f["dropped"], 0, "the slow reader skipped some")
        self.assertGreaterEqual(f["path_bytes"], 64 * f["path_messages"])
        self.assertGreaterEqual(f["messages_out"], f["path_messages"])
        self.assertGreaterEqual(f["bytes_out"], f["path_bytes"])

    def test_the_owner_counts_what_goes_on_paths_only(self):
        """EV_PHYS_RELAY 0 (every subscriber has a path): the owner publishes to the hub no more
        and counts instead (PHYS_COUNT): the channel's messages grow, the owner's flow's do
        not."""
        from PySketch.flowsync import FlowSync
        pub = self.publisher("shm")
        s = self.subscriber(PATH_SHM)
        self.onPath(pub, s)
        stats = FlowSync(self.hub.address, "guest", "password")
        self.assertTrue(stats.connect())
        self.addCleanup(stats.close)

        def now():
            st = stats.serviceCall("hub.inspect", "stats")
            ch = [c for c in st["channels"] if c["name"] == "guest.frames"][0]
            owner = [f for f in st["flows"] if f["id"] == ch["owner_flow"]][0]
            return ch["messages"], owner["messages_in"]
        tickFor([s], 1.5)   # the owner heard EV_PHYS_RELAY 0, and counted what came before
        m0, in0 = now()
        pub.do("pub 50 64", "^published", [s])
        seen = [None]

        def counted():
            seen[0] = now()
            return seen[0][0] >= m0 + 50
        self.assertTrue(pump([s], counted), (m0, in0, seen[0]))
        tickFor([s], 1.2)
        m1, in1 = now()
        self.assertEqual(m1 - m0, 50, "PHYS_COUNT: the hub counts them once")
        self.assertLess(in1 - in0, 10, "not published to the hub (%d frames in)" % (in1 - in0))

    def deadOwner(self, kinds, kind):
        pub = self.publisher(kinds)
        s = self.subscriber(kind)
        removed = []
        s.setDelChanCallBack(lambda ch: removed.append(ch.name))
        self.onPath(pub, s)
        pub.send("slow 100000 4000")   # a message per loop, at 200 Hz
        paths = s.pathStats()["path_messages"]
        self.assertTrue(pump([s], lambda: s.pathStats()["path_messages"] > paths + 20))
        pub.kill(signal.SIGKILL)       # while its reader reads
        self.assertTrue(pump([s], lambda: "guest.frames" in removed), s.pathStats())
        tickFor([s], 1.0)
        self.assertTrue(s.isOnline())
        self.assertEqual(s.got, sorted(set(s.got)))
        # A new owner of the same channel: subscribed again by name, and by a path again.
        pub2 = self.publisher(kinds)
        self.assertTrue(pump([s], lambda: pub2.count("^subscribed") > 0), pub2.output())
        s.got = []
        self.onPath(pub2, s)
        self.assertTrue(s.got)

    def test_owner_killed_while_reading_shm(self):
        self.deadOwner("shm", PATH_SHM)

    def test_owner_killed_while_reading_direct(self):
        self.deadOwner("direct", PATH_DIRECT)

    def test_paths_again_after_the_hub_restarts(self):
        pub = self.publisher("shm")
        s = self.subscriber(PATH_SHM)
        self.onPath(pub, s)
        self.hub.stop()   # the owner closes its paths too (it lost the hub)
        self.assertTrue(pump([s], lambda: not s.isOnline()))
        self.hub.start()
        self.assertTrue(pump([s], lambda: s.isOnline(), LONG))
        self.assertTrue(pump([s], lambda: pub.count("^subscribed") >= 2, LONG), pub.output())
        paths = s.pathStats()["path_messages"]
        s.got = []
        ok = pump([s], lambda: (pub.do("pub 1 64", "^published", [s]) or True) and
                  s.pathStats()["path_messages"] > paths, LONG)
        self.assertTrue(ok, (s.pathStats(), pub.output()))
        self.assertEqual(s.got, sorted(set(s.got)), "in order, none twice")

    def test_a_path_that_cannot_be_had_stays_relayed(self):
        pub = self.publisher("direct")  # shared memory asked, direct offered
        s = self.subscriber(PATH_SHM)
        errors = []
        s.setErrorCallBack(errors.append)
        self.assertTrue(pump([s], lambda: pub.count("^subscribed") > 0), pub.output())
        for _ in range(20):
            pub.do("pub 1 64", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in s.got))
        self.assertEqual(s.got, list(range(last - len(s.got) + 1, last + 1)))
        self.assertGreaterEqual(len(s.got), 20)
        st = s.pathStats()
        self.assertEqual((st["path_messages"], st["fallbacks"]), (0, 0))
        self.assertEqual(errors, [], "a refused path is not the sketch's error")

    def test_a_hub_of_1_6_relays(self):
        import PySketch.abstractflow as af
        old = af.PROTOCOL_MINOR
        af.PROTOCOL_MINOR = 6   # this flow says 1.6: the connection's minor is 6
        try:
            pub = self.publisher("both")
            s = self.subscriber(PATH_SHM | PATH_DIRECT)
        finally:
            af.PROTOCOL_MINOR = old
        self.assertEqual(s.hubMinor, 6)
        sent = []
        send = s._send
        s._send = lambda data: sent.append(bytes(data[4:5])) or send(data)
        self.assertTrue(pump([s], lambda: pub.count("^subscribed") > 0), pub.output())
        for _ in range(10):
            pub.do("pub 1 64", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in s.got))
        self.assertEqual(s.pathStats()["path_messages"], 0)
        pub.do("stats", "^stats", [s])
        self.assertIn("served_shm=0 served_direct=0", pub.last())
        s.usePaths("guest.frames", PATH_SHM)   # asked again while subscribed: still nothing
        tickFor([s], 0.2)
        self.assertNotIn(b"\xf1", sent, "no PHYS_REQUEST on a 1.6 connection")


@unittest.skipUnless(PATHS, "paths need Python 3 (recvmsg, memfd)")
class PathsOverTcp(unittest.TestCase):
    """A subscriber that comes over TCP (another machine, as far as the hub can tell) gets the
    owner's TCP endpoint (ROBOT_PATH_TCP) and connects to it without blocking its loop."""

    def test_a_direct_path_over_tcp(self):
        self.directPathAt("127.0.0.1:0", "127.0.0.1", "paths-tcp")

    def test_a_direct_path_over_ipv6(self):
        try:
            probe = socket.socket(socket.AF_INET6, socket.SOCK_STREAM)
            probe.bind(("::1", 0))
            probe.close()
        except (socket.error, OSError):
            self.skipTest("no IPv6 loopback on this machine")
        self.directPathAt("[::1]:0", "[::1]", "paths-tcp6")

    def directPathAt(self, pathTcp, offered, name):
        from PySketch.flowsat import FlowSat
        from tests.test_tls import PASSWORD, USER, TlsHub
        hub = TlsHub(name, None, tls=False).start()
        self.addCleanup(hub.close)
        os.environ["ROBOT_PATH_TCP"] = pathTcp
        try:
            pub = Publisher(hub, "both")
        finally:
            del os.environ["ROBOT_PATH_TCP"]
        self.addCleanup(pub.close)
        self.assertTrue(waitUntil(lambda: pub.count("^ready ") > 0, TIMEOUT), pub.output())
        s = FlowSat()
        s.setLogin(USER, PASSWORD)
        s.setTickTimer(0.005)
        self.assertTrue(s.connect("tcp:127.0.0.1:%d" % hub.port()), hub.log()[-2000:])
        self.addCleanup(s.close)
        got = []
        s.setGrabDataCallBack(lambda chan, data: got.append(number(data)))
        s.usePaths("guest.frames", PATH_SHM | PATH_DIRECT)
        s.subscribeChannel("guest.frames")
        deadline = monotonic() + LONG
        while s.pathStats()["path_messages"] == 0 and monotonic() < deadline:
            pub.do("pub 1 64", "^published", [s])
            tickFor([s], 0.05)
        self.assertGreater(s.pathStats()["path_messages"], 0, (s.pathStats(), pub.output()))
        self.assertIn("tcp:%s:" % offered, hub.log(), "offered on TCP as well")
        before = s.pathStats()["path_messages"]
        del got[:]
        pub.do("pub 100 3000", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in got), (len(got), s.pathStats()))
        self.assertEqual(got, list(range(last - 99, last + 1)), "all, in order, once")
        self.assertEqual(s.pathStats()["path_messages"], before + 100)
        pub.do("stats", "^stats", [s])
        self.assertIn("served_shm=0 served_direct=1", pub.last())


@unittest.skipUnless(PATHS, "paths need Python 3 (recvmsg, memfd)")
class PathsFromAModule(HubTestCase):
    """A module as the owner (plugin ABI 1.7): tests/modules/paths_camera.c publishes
    "frame <n> " and 2000 bytes of chr(97 + n % 26) on each fast tick while subscribed, every
    other frame filled in a shared-memory slot in place."""
    modules = ("test_paths_camera",)
    CHANNEL = "test_paths_camera.frames"

    @staticmethod
    def frameNumber(view):
        b = bytes(view)
        head, _, fill = b.partition(b" ")[2].partition(b" ")
        n = int(head)
        if fill != bytes([97 + n % 26]) * 2000:
            raise AssertionError("frame %d: wrong content %r" % (n, b[:40]))
        return n

    def test_shared_memory_from_a_module(self):
        s = self.connected()
        viewed, got = [], []
        s.setGrabDataViewCallBack(lambda chan, view: viewed.append(
            (self.frameNumber(view), view.readonly)))
        s.setGrabDataCallBack(lambda chan, data: got.append(self.frameNumber(data)))
        s.usePaths(self.CHANNEL, PATH_SHM)
        s.subscribeChannel(self.CHANNEL)
        self.assertTrue(pump([s], lambda: s.pathStats()["path_messages"] > 0, LONG),
                        (s.pathStats(), self.hub.log()[-3000:]))
        before = s.pathStats()["path_messages"]
        del viewed[:], got[:]
        tickFor([s], 1.0)
        st = s.pathStats()
        self.assertGreater(len(got), 10, st)
        self.assertGreaterEqual(st["path_messages"] - before, len(got), "by the path")
        self.assertEqual(got, sorted(set(got)), "in order, none twice")
        self.assertEqual([n for n, _ in viewed], got, "each one viewed in place, then copied")
        self.assertTrue(all(ro for _, ro in viewed))
        self.assertEqual((st["torn"], st["fallbacks"]), (0, 0))


class PathsUnderPython2(HubTestCase):
    @unittest.skipUnless(PY2 or not PATHS, "Python 2.7 only (run_py27.sh)")
    def test_use_paths_is_accepted_and_relayed(self):
        pub = Publisher(self.hub, "both")
        self.addCleanup(pub.close)
        s = self.connected()
        got = []
        s.setGrabDataCallBack(lambda chan, data: got.append(number(data)))
        self.assertFalse(s.usePaths("guest.frames", PATH_SHM | PATH_DIRECT))
        s.subscribeChannel("guest.frames")
        self.assertTrue(pump([s], lambda: pub.count("^subscribed") > 0), pub.output())
        for _ in range(10):
            pub.do("pub 1 64", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in got))
        self.assertEqual(s.pathStats()["path_messages"], 0)


# --- without a hub: rings and owners made here ----------------------------------------------------

PAGE = 4096
MAX_FRAME = (64 << 20) + 32  # a DATA frame's length at most (paths_impl.h kMaxDataFrame)


def makeRing(slots=4, slotBytes=8192, seal=True, header=None, size=None):
    """A ring as shm_ring.cpp's writer makes it: (writable mmap, ring fd read-only, lease fd,
    eventfd, lease mmap)."""
    import fcntl
    import mmap
    stride = (64 + slotBytes + PAGE - 1) // PAGE * PAGE
    total = size if size is not None else PAGE + slots * stride
    fd = os.memfd_create("test-ring", os.MFD_ALLOW_SEALING)
    os.ftruncate(fd, total)
    m = mmap.mmap(fd, total)
    struct.pack_into("=IHHIIQQq", m, 0, *(header or (0x47524B53, 1, PAGE, slots, 4, slotBytes,
                                                     stride, 2000000000)))
    lease = os.memfd_create("test-lease", os.MFD_ALLOW_SEALING)
    os.ftruncate(lease, PAGE)
    if seal:
        fcntl.fcntl(fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW)
    fcntl.fcntl(lease, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW)
    ro = os.open("/proc/self/fd/%d" % fd, os.O_RDONLY)
    os.close(fd)
    lm = mmap.mmap(lease, PAGE)
    ev = os.eventfd(0, os.EFD_NONBLOCK)
    return m, ro, lease, ev, lm, stride


def commit(m, stride, slot, seq, payload):
    head = PAGE + slot * stride
    struct.pack_into("=Q", m, head, 2 * seq + 1)
    m[head + 64:head + 64 + len(payload)] = payload
    struct.pack_into("=QQq", m, head, 2 * seq, len(payload), 0)
    struct.pack_into("=Q", m, 64, (seq << 16) | slot)


class FakeFlow(object):
    """What Paths needs of a FlowSat."""

    def __init__(self):
        self.sent = []
        self.got = []
        self.views = []
        self._tag = 0
        self._onGrab = lambda chan, data: self.got.append(data)
        self._onGrabView = None
        self.hubMinor = 10  # PHYS_RECEIVED goes to `sent` as well

    def _nextTag(self):
        self._tag += 1
        return self._tag

    def _send(self, data):
        self.sent.append(bytes(data))
        return True

    def _call(self, kind, f, *args):
        return f(*args)

    def _deliverData(self, chan, data, start=0, end=None):
        self._onGrab(chan, bytes(data[start:end]))

    def codes(self):
        return [(b[4], b[5:]) for b in self.sent]


@unittest.skipUnless(PATHS, "paths need Python 3 (recvmsg, memfd)")
class RingReaderAlone(unittest.TestCase):
    def setUp(self):
        from PySketch import flowpaths
        self.fp = flowpaths

    def test_reads_the_newest_in_place_and_counts_what_it_missed(self):
        m, ro, lease, ev, lm, stride = makeRing()
        commit(m, stride, 0, 1, b"before")  # before the reader came: not missed
        r = self.fp.RingReader.open(ro, lease, ev)
        self.addCleanup(r.close)
        self.assertIsNone(r.claim())
        for seq in range(2, 6):
            commit(m, stride, seq % 4, seq, b"m%d" % seq)
        c = r.claim()
        self.assertEqual(bytes(r.view(c)), b"m5")
        self.assertEqual(struct.unpack_from("=Q", lm, 0)[0], 5 % 4 + 1, "the slot is leased")
        self.assertTrue(r.release(c))
        self.assertEqual(struct.unpack_from("=Q", lm, 0)[0], 0)
        self.assertEqual((r.received, r.missed, r.torn), (1, 3, 0))
        self.assertGreater(struct.unpack_from("=q", lm, 8)[0], 0, "a heartbeat")

    def test_a_slot_rewritten_during_the_read_is_torn(self):
        m, ro, lease, ev, lm, stride = makeRing()
        r = self.fp.RingReader.open(ro, lease, ev)
        self.addCleanup(r.close)
        commit(m, stride, 1, 1, b"first")
        c = r.claim()
        commit(m, stride, 1, 2, b"other")  # a writer that ignores the lease
        self.assertFalse(r.release(c))
        self.assertEqual(r.torn, 1)

    def test_refuses_rings_that_do_not_add_up(self):
        cases = {
            "not sealed": dict(seal=False),
            "bad magic": dict(header=(0x1234, 1, PAGE, 4, 4, 8192, 3 * PAGE, 1)),
            "size mismatch": dict(size=PAGE + 4 * 3 * PAGE + PAGE),
            "stride": dict(header=(0x47524B53, 1, PAGE, 4, 4, 8192, 4 * PAGE, 1)),
            "huge slots": dict(header=(0x47524B53, 1, PAGE, 1 << 20, 4, 8192, 3 * PAGE, 1)),
        }
        for what, kw in cases.items():
            m, ro, lease, ev, lm, stride = makeRing(**kw)
            before = len(os.listdir("/proc/self/fd"))
            with self.assertRaises(self.fp.RingRefused, msg=what):
                self.fp.RingReader.open(ro, lease, ev)
            self.assertEqual(len(os.listdir("/proc/self/fd")), before - 3, "all three closed")
        # Not a memfd at all.
        with tempfile.TemporaryFile() as f:
            f.truncate(2 * PAGE)
            m, ro, lease, ev, lm, stride = makeRing()
            with self.assertRaises(self.fp.RingRefused):
                self.fp.RingReader.open(os.dup(f.fileno()), lease, ev)
            os.close(ro)

    def test_a_malicious_owner_cannot_make_it_read_outside(self):
        m, ro, lease, ev, lm, stride = makeRing()
        r = self.fp.RingReader.open(ro, lease, ev)
        self.addCleanup(r.close)
        struct.pack_into("=Q", m, 64, (7 << 16) | 4000)      # a slot index outside the ring
        self.assertIs(r.claim(), False)
        head = PAGE + 2 * stride
        struct.pack_into("=QQq", m, head, 16, 1 << 40, 0)      # a length beyond the slot
        struct.pack_into("=Q", m, 64, (8 << 16) | 2)
        self.assertIs(r.claim(), False)
        self.assertEqual(r.torn, 2)


@unittest.skipUnless(PATHS, "paths need Python 3 (recvmsg, memfd)")
class PathsWithAFakeOwner(unittest.TestCase):
    """Paths against an owner written here: the framing, the marker rule, fallback."""

    def setUp(self):
        from PySketch import flowpaths
        self.fp = flowpaths
        self.dir = tempfile.mkdtemp(prefix="pypaths-")
        self.where = os.path.join(self.dir, "owner")
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.listener.bind(self.where)
        self.listener.listen(4)
        self.flow = FakeFlow()
        self.paths = flowpaths.Paths(self.flow)
        self.addCleanup(self.cleanup)

    def cleanup(self):
        self.paths.reset()
        self.listener.close()
        os.unlink(self.where)
        os.rmdir(self.dir)

    def open(self, kind=PATH_DIRECT, fds=None):
        """Asks, is granted, connects; the owner answers WELCOME. Returns the owner's socket."""
        self.paths.want("guest.frames", kind)
        self.paths.onSubscribed("guest.frames", 5)
        code, body = self.flow.codes()[-1]
        self.assertEqual(code, 0xF1)
        tag = struct.unpack_from("<I", body)[0]
        self.paths.onPath(tag, 5, kind, "unix:" + self.where, "0" * 32)
        owner, _ = self.listener.accept()
        hello = owner.recv(4096)
        self.assertEqual(hello[4], 1)
        welcome = struct.pack("<IBHH", 5, 2, 0, 0)
        if fds:
            owner.sendmsg([welcome], [(socket.SOL_SOCKET, socket.SCM_RIGHTS,
                                       struct.pack("=%di" % len(fds), *fds))])
        else:
            owner.sendall(welcome)
        self.step()
        return owner

    def step(self):
        import select
        fds = self.paths.fds()
        if fds:
            r, _, _ = select.select(fds, [], [], 2.0)
            self.paths.ready(r)

    def data(self, seq, payload):
        return struct.pack("<IBQq", 1 + 16 + len(payload), 3, seq, 0) + payload

    def states(self):
        return [body for code, body in self.flow.codes() if code == 0xF2]

    def test_before_the_marker_nothing_is_delivered(self):
        owner = self.open()
        self.assertEqual(self.states(), [struct.pack("<HB", 5, 1)])
        owner.sendall(self.data(1, b"early"))   # may have been relayed too
        self.step()
        self.assertEqual(self.flow.got, [])
        owner.sendall(self.data(2, b"in flight"))
        self.paths.onRelay(5, 0)                  # the marker: what is already there is dropped
        owner.sendall(self.data(3, b"ours"))
        self.step()
        self.assertEqual(self.flow.got, [b"ours"])
        self.assertEqual(self.paths.stats()["dropped_before_marker"], 2)
        owner.close()

    def again(self, first=b""):
        """After a break: asked again now, granted, connected; the owner answers WELCOME and
        `first`. Returns the owner's socket."""
        self.paths._paths[5].retryAt = 0.001
        self.paths._lastTick = 0
        self.paths.tick()
        code, body = self.flow.codes()[-1]
        self.assertEqual(code, 0xF1)
        tag = struct.unpack_from("<I", body)[0]
        self.paths.onPath(tag, 5, PATH_DIRECT, "unix:" + self.where, "1" * 32)
        owner, _ = self.listener.accept()
        owner.recv(4096)
        owner.sendall(struct.pack("<IBHH", 5, 2, 0, 0) + first)
        self.step()
        self.step() if not self.paths._paths[5].open else None
        self.assertTrue(self.paths._paths[5].open)
        return owner

    def test_a_stale_marker_does_not_open_the_next_path(self):
        owner = self.open()
        owner.close()                           # breaks before its marker came
        self.step()
        self.assertEqual(self.paths.stats()["fallbacks"], 1)
        self.paths.onRelay(5, 0)                # the marker of the broken path, late
        owner = self.again(self.data(1, b"relayed too"))
        self.assertEqual(self.flow.got, [], "its marker has not come: it may be a duplicate")
        self.paths.onRelay(5, 0)
        owner.sendall(self.data(2, b"ours"))
        self.step()
        self.assertEqual(self.flow.got, [b"ours"])
        owner.close()

    def test_a_numbered_marker_drops_what_was_relayed_and_delivers_the_rest(self):
        owner = self.open()
        m = [self.data(n, b"m%d" % n) for n in range(8)]
        owner.sendall(m[1] + m[2] + m[3][:10])   # before the marker: read ahead, left alone
        self.step()
        self.assertEqual(len(self.paths._paths[5].inbuf), len(m[1] + m[2]) + 10)
        owner.sendall(m[3][10:] + m[4] + m[5] + m[6][:10])   # waits in the socket
        self.assertEqual((self.flow.got, self.paths.stats()["dropped_before_marker"]), ([], 0))
        self.paths.onMarker(5, 3)                # relayed up to message 3; the rest is ours
        self.assertEqual(self.flow.got, [b"m4", b"m5"])
        self.assertEqual(self.paths.stats()["dropped_before_marker"], 3)
        owner.sendall(m[6][10:] + m[7])
        self.step()
        self.assertEqual(self.flow.got, [b"m4", b"m5", b"m6", b"m7"],
                         "the frame half read at the marker is ours too")
        st = self.paths.stats()
        self.assertEqual((st["path_messages"], st["dropped_before_marker"]), (4, 3))
        owner.close()

    def test_the_old_marker_drops_everything_that_waits(self):
        owner = self.open()
        m = [self.data(n, b"m%d" % n) for n in range(7)]
        owner.sendall(m[1] + m[2] + m[3][:10])
        self.step()
        owner.sendall(m[3][10:] + m[4] + m[5][:10])
        self.paths.onRelay(5, 0)    # a hub or an owner before 1.9: no number
        self.assertEqual(self.flow.got, [])
        self.assertEqual(self.paths.stats()["dropped_before_marker"], 4)
        owner.sendall(m[5][10:] + m[6])
        self.step()
        self.assertEqual(self.flow.got, [b"m6"], "a frame begun before the marker is dropped")
        self.assertEqual(self.paths.stats()["dropped_before_marker"], 5)
        owner.close()

    def test_a_numbered_marker_on_shared_memory(self):
        for after, expected, dropped in ((1, [b"m2", b"m3"], 0), (2, [b"m3"], 1)):
            m, ro, lease, ev, lm, stride = makeRing()
            owner = self.open(PATH_SHM, [ro, lease, ev])
            for fd in (ro, lease, ev):
                os.close(fd)
            del self.flow.got[:]
            before = self.paths.stats()["dropped_before_marker"]
            missed = self.paths.stats()["missed"]
            commit(m, stride, 0, 1, b"m1")
            os.eventfd_write(self.paths._paths[5].ring.eventFd, 1)
            self.step()
            commit(m, stride, 1, 2, b"m2")
            self.assertEqual(self.flow.got, [], "no slot read before the marker")
            self.paths.onMarker(5, after)        # the newest (2) is read now
            commit(m, stride, 2, 3, b"m3")
            os.eventfd_write(self.paths._paths[5].ring.eventFd, 1)
            self.step()
            self.assertEqual(self.flow.got, expected, after)
            self.assertEqual(self.paths.stats()["dropped_before_marker"] - before, dropped,
                             "the newest at the marker, when it was relayed too")
            self.assertEqual(self.paths.stats()["missed"], missed,
                             "m1 was relayed, not missed (paths_subscriber.cpp readRing)")
            owner.close()
            self.paths.onUnsubscribed(5)

    def test_a_switch_cancelled_by_a_break_does_not_hold_up_the_next_path(self):
        owner = self.open()     # PHYS_STATE 1: a hub of 1.9 asks the owner to switch
        owner.close()           # broken before it answered: PHYS_STATE 0 cancels it, no marker
        self.step()
        self.assertEqual(self.states(), [struct.pack("<HB", 5, 1), struct.pack("<HB", 5, 0)])
        owner = self.again(self.data(1, b"relayed too") + self.data(2, b"ours"))
        self.assertEqual(self.states()[-1], struct.pack("<HB", 5, 1))
        self.paths.onMarker(5, 1)   # the new path's marker: the only one that comes
        self.assertEqual(self.flow.got, [b"ours"])
        owner.close()

    def test_reads_ahead_at_most_16_mb_before_the_marker(self):
        owner = self.open()
        p = self.paths._paths[5]
        frames = [self.data(n, struct.pack("<Q", n) + b"x" * (1 << 20)) for n in range(1, 21)]
        t = threading.Thread(target=owner.sendall, args=(b"".join(frames),))
        t.start()
        deadline = monotonic() + TIMEOUT
        while not p.paused and monotonic() < deadline:
            self.step()
        self.assertTrue(p.paused, len(p.inbuf))
        self.assertTrue(16 << 20 <= len(p.inbuf) <= (16 << 20) + 256 * 1024, len(p.inbuf))
        self.assertEqual(self.paths.fds(), [], "the rest waits in the socket")
        self.assertEqual(self.flow.got, [])
        self.paths.onMarker(5, 2)
        while len(self.flow.got) < 18 and monotonic() < deadline:
            self.step()
        t.join(TIMEOUT)
        self.assertEqual([struct.unpack_from("<Q", g)[0] for g in self.flow.got],
                         list(range(3, 21)), "all after the marker's, in order")
        self.assertEqual(self.paths.stats()["fallbacks"], 0)
        owner.close()

    def test_a_hang_up_while_the_read_ahead_waits_falls_back(self):
        owner = self.open()
        p = self.paths._paths[5]

        def send():   # one frame beyond the read-ahead, then gone
            owner.sendall(self.data(1, b"x" * ((16 << 20) + 1000)))
            owner.close()
        t = threading.Thread(target=send)
        t.start()
        deadline = monotonic() + TIMEOUT
        while not p.paused and monotonic() < deadline:
            self.step()
        t.join(TIMEOUT)
        self.assertTrue(p.paused)
        self.assertEqual(self.paths.stats()["fallbacks"], 0)
        self.paths._lastTick = 0
        self.paths.tick()      # not read, but watched for a hang-up
        self.assertEqual(self.paths.stats()["fallbacks"], 1)
        self.assertEqual(self.states()[-1], struct.pack("<HB", 5, 0), "relayed again")
        self.assertEqual(self.paths.fds(), [])

    def test_breaks_fall_back_to_the_relay(self):
        breaks = {
            "over-long frame": struct.pack("<IB", 0xFFFFFFF0, 3),
            "zero length": struct.pack("<I", 0),
            "unknown frame": struct.pack("<IB", 1, 9),
            "short data": struct.pack("<IBQ", 9, 3, 1),
            "bye": struct.pack("<IBH", 3, 4, 0),
        }
        for n, (what, frame) in enumerate(sorted(breaks.items())):
            owner = self.open()
            self.paths.onRelay(5, 0)
            owner.sendall(self.data(1, b"fine") + frame)
            self.step()
            self.assertEqual(self.paths.stats()["fallbacks"], n + 1, what)
            self.assertEqual(self.states()[-1], struct.pack("<HB", 5, 0), what)
            self.assertEqual(self.paths.fds(), [], what)
            owner.close()
            self.paths.onUnsubscribed(5)
        self.assertEqual(self.flow.got, [b"fine"] * len(breaks))

    def test_an_over_long_frame_is_refused_before_its_bytes_are_read(self):
        owner = self.open()
        self.paths.onRelay(5, 0)
        sent = []

        def flood():   # a length over the limit, then more than the reader may ever buffer
            try:
                owner.sendall(struct.pack("<IB", MAX_FRAME + 1, 3) + b"x" * (64 << 20))
                sent.append("all")
            except (socket.error, OSError):
                sent.append("refused")
        t = threading.Thread(target=flood)
        t.start()
        self.step()
        self.assertEqual(self.paths.stats()["fallbacks"], 1)
        self.assertEqual(self.paths.fds(), [])
        t.join(TIMEOUT)
        self.assertEqual(sent, ["refused"], "the path closed before the 64 MB were read")
        owner.close()

    def test_a_refused_welcome_and_a_refused_ring_fall_back(self):
        self.paths.want("guest.frames", PATH_SHM)
        # WELCOME with an error.
        self.paths.onSubscribed("guest.frames", 5)
        tag = struct.unpack_from("<I", self.flow.codes()[-1][1])[0]
        self.paths.onPath(tag, 5, PATH_SHM, "unix:" + self.where, "0" * 32)
        owner, _ = self.listener.accept()
        owner.recv(4096)
        owner.sendall(struct.pack("<IBHH", 9, 2, 7, 4) + b"nope")
        self.step()
        self.assertEqual(self.paths.stats()["fallbacks"], 1)
        self.assertEqual(self.states(), [], "never open: no PHYS_STATE")
        owner.close()
        # A ring that is not sealed: refused, its descriptors closed.
        m, ro, lease, ev, lm, stride = makeRing(seal=False)
        before = len(os.listdir("/proc/self/fd"))
        owner = self.open(PATH_SHM, [ro, lease, ev])
        for fd in (ro, lease, ev):
            os.close(fd)
        owner.close()
        self.assertEqual(self.paths.stats()["fallbacks"], 2)
        self.assertEqual(len(os.listdir("/proc/self/fd")), before - 3, "nothing leaked")

    def test_a_torn_read_is_not_delivered(self):
        m, ro, lease, ev, lm, stride = makeRing()
        owner = self.open(PATH_SHM, [ro, lease, ev])
        for fd in (ro, lease, ev):
            os.close(fd)
        commit(m, stride, 0, 1, b"early")   # before the marker: may have been relayed too
        os.eventfd_write(self.paths._paths[5].ring.eventFd, 1)
        self.step()
        self.assertEqual(self.flow.got, [])
        self.assertEqual(self.paths.stats()["dropped_before_marker"], 0, "not read before it")
        self.paths.onRelay(5, 0)                 # no number: the newest waiting is dropped
        self.assertEqual(self.paths.stats()["dropped_before_marker"], 1)
        views = []

        def rewrite(chan, view):   # a writer that ignores the lease, during the read
            views.append(bytes(view))
            commit(m, stride, 1, 3, b"XXXXX")
        self.flow._onGrabView = rewrite
        commit(m, stride, 1, 2, b"hello")
        os.eventfd_write(self.paths._paths[5].ring.eventFd, 1)
        self.step()
        self.assertEqual(views, [b"hello"])
        self.assertEqual(self.flow.got, [], "a torn read never reaches the bytes callback")
        st = self.paths.stats()
        self.assertEqual((st["torn"], st["path_messages"]), (1, 0))
        self.flow._onGrabView = None
        commit(m, stride, 2, 4, b"good")
        os.eventfd_write(self.paths._paths[5].ring.eventFd, 1)
        self.step()
        self.assertEqual(self.flow.got, [b"good"])
        owner.close()

    def test_paths_given_up_while_open_go_back_to_the_relay(self):
        owner = self.open()
        self.paths.onRelay(5, 0)
        self.paths.want("guest.frames", 0)           # what FlowSat.usePaths(name, 0) does
        self.paths.onSubscribed("guest.frames", 5)
        self.assertEqual(self.states()[-1], struct.pack("<HB", 5, 0), "relayed again")
        self.assertEqual(self.paths.fds(), [])
        self.assertEqual(self.flow.codes()[-1][0], 0xF2, "and no new PHYS_REQUEST")
        self.assertEqual(self.paths.stats()["fallbacks"], 0, "not a break")
        owner.close()

    def test_a_callback_may_unsubscribe_while_it_reads_the_ring(self):
        m, ro, lease, ev, lm, stride = makeRing()
        owner = self.open(PATH_SHM, [ro, lease, ev])
        for fd in (ro, lease, ev):
            os.close(fd)
        self.paths.onRelay(5, 0)
        kept = []

        def leave(chan, view):
            kept.append(ringArray(view) if ringArray(view) is not None else view)
            self.paths.onUnsubscribed(5)     # the path and its ring go away under the view
            self.assertEqual(bytes(view), b"bye")
        from PySketch.flowpaths import ringArray
        self.flow._onGrabView = leave
        commit(m, stride, 0, 1, b"bye")
        os.eventfd_write(self.paths._paths[5].ring.eventFd, 1)
        self.step()
        self.assertEqual(self.paths.fds(), [])
        self.assertEqual(self.flow.got, [])
        self.assertEqual(bytes(bytearray(kept[0])), b"bye", "still mapped while it is kept")
        owner.close()


if __name__ == "__main__":
    unittest.main()
