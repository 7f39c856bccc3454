# SPDX-License-Identifier: Apache-2.0
"""FlowSat.publish() takes any object with the buffer protocol (numpy arrays, memoryview,
bytearray, array.array; bytes and str under 2.7), sends it without an intermediate bytes copy
(Python 3: a gathered write; what the socket cannot take is copied into the output buffer),
and leaves the caller free to reuse its buffer once it returns."""
from __future__ import print_function

import array
import struct
import sys
import unittest

from PySketch.databuffer import DataBuffer
from PySketch.flowproto import Flow_T, Variant_T

from tests.compat import PY2
from tests.hubtest import HubTestCase, pump

try:
    import numpy
except ImportError:
    numpy = None
try:
    import tracemalloc
except ImportError:  # Python 2.7
    tracemalloc = None

VGA = (480, 640, 3)       # 921,600 bytes
HD = (1080, 1920, 3)      # 6,220,800 bytes


def _pattern(n, seed):
    """n bytes repeating with a period of 251 (a prime), starting at `seed`: a shifted or
    truncated copy shows."""
    period = bytearray(range(251))
    period = period[seed:] + period[:seed]
    return (period * (n // 251 + 1))[:n]


class Publish(HubTestCase):
    def pair(self):
        """A publisher with its channel guest.frames and a subscriber collecting the bytes."""
        pub, sub = self.connected(), self.connected()
        got = []
        sub.setGrabDataCallBack(lambda chanID, data: got.append(data))
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "frames"))
        self.assertTrue(pump([pub, sub], lambda: sub.channelByName("guest.frames") and
                             pub.channelByName("guest.frames")))
        self.assertTrue(sub.subscribeChannel("guest.frames"))
        mine = pub.channelByName("guest.frames")
        self.assertTrue(pump([pub, sub], lambda: mine.isPublishingEnabled))
        return pub, sub, mine, got

    def assertArrive(self, pub, sub, got, expected):
        self.assertTrue(pump([pub, sub], lambda: len(got) >= len(expected)),
                        "%d of %d messages arrived" % (len(got), len(expected)))
        self.assertEqual(len(got), len(expected))
        for i, (a, b) in enumerate(zip(got, expected)):
            self.assertEqual(len(a), len(b), "message %d: %d bytes, expected %d"
                             % (i, len(a), len(b)))
            self.assertTrue(a == b, "message %d differs" % i)

    def test_every_kind_of_buffer_arrives_as_its_bytes(self):
        pub, sub, mine, got = self.pair()
        floats = array.array("f", [1.0, 2.5, -3.0])
        cases = [
            (b"bytes", b"bytes"),
            (bytearray(b"bytearray"), b"bytearray"),
            (memoryview(bytearray(b"memoryview")), b"memoryview"),
            (floats, struct.pack("<fff", 1.0, 2.5, -3.0)),
            (array.array("h", [-2, 7]), struct.pack("<hh", -2, 7)),
            (DataBuffer().setFloat([0.5]), struct.pack("<f", 0.5)),
            (u"h\u00e9", u"h\u00e9".encode("utf-8")),
            (bytearray(), b""),
        ]
        if PY2:
            cases.append((str("native str"), b"native str"))
        else:
            cases += [
                (memoryview(floats), struct.pack("<fff", 1.0, 2.5, -3.0)),  # format "f"
                (memoryview(b"abcdef")[::2], b"ace"),                        # not contiguous
                (memoryview(bytearray(b"0123456789ab")).cast("B", (3, 4)), b"0123456789ab"),
            ]
        for data, _ in cases:
            self.assertTrue(pub.publish(mine, data), type(data).__name__)
        self.assertArrive(pub, sub, got, [b for _, b in cases])
        self.assertTrue(all(isinstance(d, bytes) for d in got))

    def test_the_caller_may_reuse_its_buffer_once_publish_returns(self):
        # 6 MB: more than a Unix socket takes at once, so most of it waits in the flow's
        # output buffer when publish() returns; overwriting and resizing the caller's buffer
        # then must change nothing of what was published.
        pub, sub, mine, got = self.pair()
        first = _pattern(6 << 20, 1)
        buf = bytearray(first)
        self.assertTrue(pub.publish(mine, buf))
        buf[:] = _pattern(6 << 20, 2)
        buf.extend(b"tail")                    # no export of it is left behind
        self.assertTrue(pub.publish(mine, buf))
        floats = array.array("d", range(100000))
        self.assertTrue(pub.publish(mine, floats))
        floats[0] = -1.0
        floats.append(1.0)
        self.assertArrive(pub, sub, got, [bytes(first), bytes(_pattern(6 << 20, 2)) + b"tail",
                                          struct.pack("<100000d", *range(100000))])

    def test_anything_else_is_a_clear_type_error(self):
        pub, sub, mine, got = self.pair()
        for bad in (3.5, None, [1, 2], object()):
            with self.assertRaises(TypeError) as raised:
                pub.publish(mine, bad)
            self.assertIn("bytes-like data (bytes, bytearray, memoryview, array.array, a numpy "
                          "array", str(raised.exception))
            self.assertIn(type(bad).__name__, str(raised.exception))
        self.assertTrue(pub.publish(mine, b"still fine"))
        self.assertArrive(pub, sub, got, [b"still fine"])

    @unittest.skipIf(numpy is None, "numpy is not installed for %s" % sys.executable)
    def test_numpy_frames_arrive_byte_for_byte(self):
        pub, sub, mine, got = self.pair()
        hd = (numpy.arange(numpy.prod(HD), dtype=numpy.uint32) * 2654435761 >> 13).astype(
            numpy.uint8).reshape(HD)
        vga = numpy.ascontiguousarray(hd[:VGA[0], :VGA[1]])
        depth = numpy.linspace(0.0, 10.0, 640 * 480, dtype=numpy.float32).reshape(480, 640)
        odd = hd[::2, ::3]                     # a view with steps: copied once, in C order
        frames = [hd, vga, depth, odd, depth.T, numpy.zeros(0, numpy.uint8)]
        for f in frames:
            self.assertTrue(pub.publish(mine, f))
        self.assertArrive(pub, sub, got, [f.tobytes() for f in frames])
        self.assertEqual(len(got[0]), 6220800)
        self.assertEqual(len(got[1]), 921600)

    @unittest.skipIf(tracemalloc is None, "tracemalloc: Python 3")
    def test_publish_copies_at_most_what_the_socket_does_not_take(self):
        # The peak of memory allocated during publish(): at most one copy of the payload (the
        # part that waits in the output buffer), never a bytes object of it plus a frame.
        pub, sub, mine, got = self.pair()
        payloads = [bytes(_pattern(6 << 20, 3))]
        if numpy is not None:
            payloads.append(numpy.frombuffer(payloads[0], numpy.float32).reshape(1024, -1))
        for data in payloads:
            size = len(memoryview(data).cast("B"))
            self.assertTrue(pump([pub, sub], lambda: not pub._outbuf))  # nothing waits before
            tracemalloc.start()
            try:
                self.assertTrue(pub.publish(mine, data))
                peak = tracemalloc.get_traced_memory()[1]
            finally:
                tracemalloc.stop()
            self.assertLess(peak, size + (256 << 10), "publish() of %d bytes (%s) allocated "
                            "up to %d bytes" % (size, type(data).__name__, peak))
        self.assertArrive(pub, sub, got, [bytes(memoryview(p).cast("B")) for p in payloads])


if __name__ == "__main__":
    unittest.main()
