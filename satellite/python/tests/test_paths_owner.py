# SPDX-License-Identifier: Apache-2.0
"""Physical mode with a PySketch channel OWNER (PySketch/flowowner.py, docs/physical-mode.md).

test_paths.py's hub tests (PathsWithAHub) again, with tests/paths_publisher.py (the PySketch twin
of the C++ paths_publisher) as the owner: shared memory in place, a direct path in order, a
switch that loses nothing, fallback without loss or duplicates, a slow reader, the hub's counts,
an owner killed, a hub restarted. Then numpy frames built in place in the owner's ring slots
(beginPublish, mediaframe.frame_slot) read by a numpy subscriber; a C++ subscriber
(satellite/cpp/tests/paths_subscriber.cpp) on a Python owner's ring, and on its direct path that
falls back without loss when the owner resets its paths; without a hub, grants (once, for their
kind and channel, within 10 s); under Python 2.7 (run_py27.sh), a channel declared with paths=
is relayed.
"""
import os
import re
import signal
import unittest

from PySketch.flowproto import PATH_DIRECT, PATH_SHM
from tests import test_paths
from tests.compat import PY2
from tests.hubtest import TIMEOUT, HubTestCase, Sketch, pump, tickFor, waitUntil

try:
    import numpy
except ImportError:
    numpy = None


class PathsFromAPythonOwner(test_paths.PathsWithAHub):
    OWNER = test_paths.PYTHON_OWNER


W, H = 320, 240


@unittest.skipUnless(test_paths.PATHS and numpy is not None, "Python 3 and numpy")
class NumpyFramesInPlace(HubTestCase):
    """bgr8 frames filled by numpy in the owner's ring slots, checked byte for byte by a numpy
    subscriber that reads them in place: at 30 Hz none is skipped; resetPaths on the owner and
    then its death fall back to the relay without a wrong or repeated frame."""

    def test_frames_in_place_to_a_numpy_subscriber(self):
        from PySketch import mediaframe
        pub = test_paths.Publisher(self.hub, "shm", slot=32 + W * H * 3, rate=30,
                                   command=test_paths.PYTHON_OWNER)
        self.addCleanup(pub.close)
        s = self.connected()
        base = numpy.arange(W * H * 3, dtype=numpy.uint32).astype(numpy.uint8).reshape(H, W, 3)
        seen, bad = [], []

        def onView(chan, view):
            f = mediaframe.parse_frame(view)
            img = f.array()
            if not numpy.array_equal(img, base + numpy.uint8(f.seq & 0xFF)):
                bad.append(f.seq)
            seen.append(f.seq)
            del img, f
        s.setGrabDataViewCallBack(onView)
        s.usePaths("guest.frames", PATH_SHM)
        s.subscribeChannel("guest.frames")
        self.assertTrue(pump([s], lambda: pub.count("^subscribed") > 0), pub.output())
        # Frames until one comes by the path.
        ok = pump([s], lambda: (pub.count("^published") > len(seen) or
                                pub.do("frames 1 %d %d" % (W, H), "^published", [s]) or True)
                  and s.pathStats()["path_messages"] > 0, test_paths.LONG)
        self.assertTrue(ok, (s.pathStats(), pub.output()))
        tickFor([s], 0.2)
        before = s.pathStats()
        del seen[:]
        pub.do("frames 60 %d %d" % (W, H), "^published", [s], timeout=20)
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in seen), (seen, s.pathStats()))
        st = s.pathStats()
        self.assertEqual(seen, list(range(last - 59, last + 1)), "each frame once, none skipped")
        self.assertEqual(bad, [], "byte for byte")
        self.assertEqual(st["path_messages"] - before["path_messages"], 60, "by the ring")
        self.assertEqual((st["missed"], st["torn"]), (before["missed"], 0))
        # The owner breaks its paths: relayed meanwhile, in order, none twice, none wrong.
        pub.send("reset")
        pub.do("frames 30 %d %d" % (W, H), "^published", [s], timeout=20)
        last = int(pub.last().split()[1])
        self.assertTrue(pump([s], lambda: last in seen), (seen[-5:], s.pathStats()))
        self.assertGreaterEqual(s.pathStats()["fallbacks"], 1)
        self.assertEqual(seen, sorted(set(seen)))
        self.assertEqual(bad, [])
        # The owner dies while it streams: the subscriber stays online, its channel goes.
        removed = []
        s.setDelChanCallBack(lambda ch: removed.append(ch.name))
        pub.send("frames 1000 %d %d" % (W, H))
        n = len(seen)
        self.assertTrue(pump([s], lambda: len(seen) > n + 5))
        pub.kill(signal.SIGKILL)
        self.assertTrue(pump([s], lambda: "guest.frames" in removed), s.pathStats())
        tickFor([s], 0.5)
        self.assertTrue(s.isOnline())
        self.assertEqual(seen, sorted(set(seen)))
        self.assertEqual(bad, [])


def subscriberBin():
    path = os.environ.get("SKROBOT_PATHS_SUBSCRIBER")
    if not path or not os.path.exists(path):
        raise unittest.SkipTest("no paths_subscriber (set SKROBOT_PATHS_SUBSCRIBER)")
    return path


class CppSubscriber(test_paths.Commanded):
    """paths_subscriber as a subprocess: its stats as a dict of ints."""

    def __init__(self, hub, kinds):
        Sketch.__init__(self, [subscriberBin(), hub.address, "guest.frames", kinds], env=None,
                        stdin=True)

    def stats(self):
        before = len(self.matching("^stats "))
        self.send("stats")
        if not waitUntil(lambda: len(self.matching("^stats ")) > before, TIMEOUT):
            raise AssertionError("no stats:\n" + self.output())
        line = self.matching("^stats ")[-1]
        return dict((k, int(v)) for k, v in re.findall(r"(\w+)=(\d+)", line))


@unittest.skipUnless(test_paths.PATHS, "paths need Python 3 (recvmsg, memfd)")
class CppSubscriberOnAPythonOwner(HubTestCase):
    def setUpPair(self, kinds):
        sub = CppSubscriber(self.hub, kinds)
        self.addCleanup(sub.close)
        pub = test_paths.Publisher(self.hub, kinds, command=test_paths.PYTHON_OWNER)
        self.addCleanup(pub.close)
        self.assertTrue(waitUntil(lambda: pub.count("^subscribed") > 0, TIMEOUT), pub.output())
        # Messages until one comes by the path.
        for _ in range(300):
            pub.do("pub 1 64", "^published")
            if sub.stats()["path_messages"] > 0:
                break
        self.assertGreater(sub.stats()["path_messages"], 0, (sub.output(), pub.output()))
        return pub, sub

    def test_shared_memory(self):
        pub, sub = self.setUpPair("shm")
        before = sub.stats()["path_messages"]
        for _ in range(20):   # one at a time, each waited for: newest wins loses none then
            pub.do("zc 1 40000", "^published")
            last = int(pub.last().split()[1])
            self.assertTrue(waitUntil(lambda: sub.stats()["last"] >= last), sub.stats())
        st = sub.stats()
        self.assertEqual(st["path_messages"] - before, 20, st)
        self.assertEqual((st["bad"], st["torn"], st["ordered"], st["fallbacks"]), (0, 0, 1, 0))

    def test_direct_path_falls_back_without_loss(self):
        pub, sub = self.setUpPair("direct")
        sub.send("clear")
        sub.waitFor("^cleared")
        first = int(pub.last().split()[1]) + 1
        pub.do("pub 100 64", "^published")
        pub.send("reset")   # and at once more, before the hub hears of the break
        for _ in range(10):
            pub.do("pub 20 64", "^published")
        last = int(pub.last().split()[1])
        self.assertTrue(waitUntil(lambda: sub.stats()["last"] >= last, TIMEOUT), sub.stats())
        st = sub.stats()
        self.assertEqual((st["first"], st["last"], st["got"]), (first, last, last - first + 1),
                         "every message once (1.11: the owner replays what the path lost)")
        self.assertEqual((st["ordered"], st["gaps"], st["bad"]), (1, 0, 0), st)
        self.assertGreaterEqual(st["fallbacks"], 1)


class _FakeFlow(object):
    """What Owner uses of a FlowSat: frames sent (code, body) kept."""
    hubMinor = 13

    def __init__(self):
        self.sent = []
        self.tag = 0

    def _nextTag(self):
        self.tag += 1
        return self.tag

    def _send(self, data):
        self.sent.append((bytearray(data)[4], bytes(data[5:])))
        return True


@unittest.skipUnless(test_paths.PATHS, "paths need Python 3 (recvmsg, memfd)")
class OwnerGrants(unittest.TestCase):
    """Without a hub: a grant lets one HELLO in, once, for its kind, within 10 s; anything else
    is answered WELCOME with an error (SAT-PATH-REFUSED)."""

    def setUp(self):
        from PySketch import flowowner
        self.fo = flowowner
        self.flow = _FakeFlow()
        self.owner = flowowner.Owner(self.flow)
        self.addCleanup(self.owner.close)
        self.owner.serve(7, "guest.frames", PATH_SHM | PATH_DIRECT, (4, 4096, 4))
        code, body = self.flow.sent[-1]
        self.assertEqual(code, 0xF0)  # PHYS_OFFER
        self.endpoint = body[9:].decode()
        self.assertTrue(self.endpoint.startswith("unix:/tmp/skrobot-path-"), self.endpoint)

    def later(self, seconds):
        """The owner's clock `seconds` ahead from now on."""
        now = self.fo._now
        self.fo._now = lambda: now() + seconds
        self.addCleanup(setattr, self.fo, "_now", now)

    def hello(self, kind, token, channel="guest.frames"):
        """Connects, says HELLO, runs the owner until it answers: (error, descriptors)."""
        import socket
        import struct
        c = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.addCleanup(c.close)
        c.connect(self.endpoint[5:])
        name, tok = channel.encode(), token.encode()
        body = struct.pack("<BBH", 1, kind, len(name)) + name + struct.pack("<H", len(tok)) + tok
        c.sendall(struct.pack("<IB", len(body) + 1, self.fo.HELLO) + body)
        c.settimeout(0.01)
        for i in range(200):
            self.owner.ready(self.owner.fds())
            if i == 20:   # a HELLO without its grant waits 2 s for it: 3 s later, refused
                self.later(3.0)
                self.owner.tick()
            try:
                data, fds, _, _ = socket.recv_fds(c, 4096, 8)
                break
            except socket.timeout:
                continue
        else:
            self.fail("no WELCOME")
        for fd in fds:
            os.close(fd)
        self.assertEqual(data[4], self.fo.WELCOME)
        return struct.unpack_from("<H", data, 5)[0], len(fds)

    def test_a_token_is_good_once_for_its_kind(self):
        self.owner.onGrant(7, 42, "guest/sub", PATH_SHM, "t1")
        self.assertEqual(self.hello(PATH_DIRECT, "t1"), (5, 0), "not the kind granted")
        self.owner.onGrant(7, 42, "guest/sub", PATH_SHM, "t2")
        self.assertEqual(self.hello(PATH_SHM, "t2"), (0, 3), "the ring, its lease, its eventfd")
        self.assertEqual(self.owner.stats()["served_shm"], 1)
        self.assertEqual(self.hello(PATH_SHM, "t2"), (5, 0), "once")
        self.owner.onGrant(7, 42, "guest/sub", PATH_DIRECT, "t3")
        self.assertEqual(self.hello(PATH_DIRECT, "t3", "guest.other"), (5, 0), "its channel")

    def test_a_token_expires_after_10_s(self):
        self.owner.onGrant(7, 42, "guest/sub", PATH_DIRECT, "t1")
        self.later(10.5)
        self.assertEqual(self.hello(PATH_DIRECT, "t1"), (5, 0))


class OwnerUnderPython2(HubTestCase):
    @unittest.skipUnless(PY2 or not test_paths.PATHS, "Python 2.7 only (run_py27.sh)")
    def test_a_channel_with_paths_is_relayed(self):
        """paths= is accepted and logged once; publish and beginPublish/commitPublish (a buffer
        of the flow's) go through the hub."""
        pub = test_paths.Publisher(self.hub, "both", command=test_paths.PYTHON_OWNER)
        self.addCleanup(pub.close)
        s = self.connected()
        got = []
        s.setGrabDataCallBack(lambda chan, data: got.append(test_paths.number(data)))
        s.subscribeChannel("guest.frames")
        self.assertTrue(pump([s], lambda: pub.count("^subscribed") > 0), pub.output())
        pub.do("pub 5 64", "^published", [s])
        pub.do("zc 5 3000", "^published", [s])
        last = int(pub.last().split()[1])
        self.assertEqual(last, 10, pub.output())
        self.assertTrue(pump([s], lambda: last in got), (got, pub.output()))
        self.assertEqual(got, list(range(1, 11)))
        pub.do("stats", "^stats", [s])
        self.assertIn("served_shm=0 served_direct=0", pub.last())
        self.assertEqual(pub.count("cannot offer paths"), 1, pub.output())


if __name__ == "__main__":
    unittest.main()
