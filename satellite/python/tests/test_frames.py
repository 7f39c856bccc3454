# SPDX-License-Identifier: Apache-2.0
"""Relayed messages reach a Python subscriber without copies (PySketch/frameinput.py): content
byte for byte at 6 MB, the view callback's memoryview into the flow's reused input buffer (no
allocation of a frame's size per message), what a view kept after its callback does, and a frame
over the limit refused before anything is allocated for it."""
from __future__ import print_function

import struct
import unittest

from PySketch import mediaframe
from PySketch.flowproto import Flow_T, ProtocolError, Variant_T
from PySketch.frameinput import MIN_READ, FrameInput

from tests.compat import PY2, TextIO, redirect_stderr
from tests.hubtest import HubTestCase, pump

try:
    import tracemalloc
except ImportError:  # Python 2.7
    tracemalloc = None
try:
    import numpy
except ImportError:
    numpy = None

BIG = 6 * 1024 * 1024 + 5   # a 1080p bgr8 frame and an odd tail


def payload(n, size=BIG):
    """Message n: bytes 0-3 its number, byte i (n * 7 + i) & 0xFF."""
    out = bytearray((n * 7 + i) & 0xFF for i in range(256)) * (size // 256 + 1)
    del out[size:]
    struct.pack_into("<I", out, 0, n)
    return out


class Relay(HubTestCase):
    def pair(self):
        pub = self.connected()
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "video"))
        self.assertTrue(pump([pub], lambda: pub.channelByName("guest.video")))
        sub = self.connected()
        self.assertTrue(pump([sub], lambda: sub.channelByName("guest.video")))
        self.assertTrue(sub.subscribeChannel("guest.video", queueBytes=64 << 20))
        mine = pub.channelByName("guest.video")
        self.assertTrue(pump([pub, sub], lambda: mine.isPublishingEnabled))
        return pub, mine.chanID, sub

    def test_six_megabytes_arrive_byte_for_byte_to_both_callbacks(self):
        pub, chan, sub = self.pair()
        sent = [payload(n) for n in range(3)]
        viewed, copied = [], []
        sub.setGrabDataViewCallBack(lambda c, view: viewed.append(view.tobytes()))
        sub.setGrabDataCallBack(lambda c, data: copied.append(data))
        for p in sent:
            self.assertTrue(pub.publish(chan, p))
        self.assertTrue(pump([pub, sub], lambda: len(copied) >= len(sent)))
        for i, p in enumerate(sent):
            self.assertEqual(len(viewed[i]), BIG)
            self.assertTrue(viewed[i] == bytes(p), "message %d differs (view)" % i)
            self.assertTrue(copied[i] == bytes(p), "message %d differs (bytes)" % i)
            self.assertIsInstance(copied[i], bytes)  # str under Python 2.7

    @unittest.skipIf(tracemalloc is None, "tracemalloc: Python 3")
    def test_a_view_callback_costs_no_allocation_of_the_frames_size(self):
        pub, chan, sub = self.pair()
        sums = []
        sub.setGrabDataViewCallBack(lambda c, view: sums.append((len(view), view[BIG - 1])))
        self.assertTrue(pub.publish(chan, payload(0)))
        self.assertTrue(pump([pub, sub], lambda: sums))  # the input has grown to a frame
        while pub._outbuf:
            pub.tick()
        tracemalloc.start()
        try:
            for n in range(1, 4):
                self.assertTrue(pub.publish(chan, payload(n)))
                while pub._outbuf:  # the publisher's own buffer is not the subscriber's
                    pub.tick()
                tracemalloc.reset_peak()
                self.assertTrue(pump([sub], lambda: len(sums) > n))
                peak = tracemalloc.get_traced_memory()[1]
                # Before: each read a new bytes object, appended, then the body sliced and
                # copied twice: a peak of several frames.
                self.assertLess(peak, 1 << 20, "%d bytes allocated to receive 6 MB" % peak)
        finally:
            tracemalloc.stop()
        self.assertEqual([s[0] for s in sums], [BIG] * 4)
        self.assertLessEqual(len(sub._input.buf), BIG + 16 + MIN_READ)

    def test_a_view_kept_after_its_callback(self):
        pub, chan, sub = self.pair()
        kept = []

        def onView(c, view):
            self.assertTrue(PY2 or view.readonly)
            kept.append((view, view[:64], numpy.frombuffer(view, dtype="uint8")
                         if numpy is not None else None))
        sub.setGrabDataViewCallBack(onView)
        errs = TextIO()
        with redirect_stderr(errs):
            for n in range(3):
                self.assertTrue(pub.publish(chan, payload(n, 100000)))
                self.assertTrue(pump([pub, sub], lambda: len(kept) > n))
        view, part, array = kept[0]
        if not PY2:
            self.assertRaises(ValueError, lambda: view[0])  # released when the callback returned
        # What was made from it stays readable and shows what came later to that place.
        self.assertNotEqual(part.tobytes(), bytes(payload(0, 100000)[:64]))
        if array is not None:
            self.assertNotEqual(array[:64].tobytes(), bytes(payload(0, 100000)[:64]))
        self.assertEqual(errs.getvalue().count("kept its view"), 1, errs.getvalue())


class OverTheLimit(HubTestCase):
    def test_a_frame_over_the_limit_breaks_the_flow_before_its_allocation(self):
        pub = self.connected()
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "video"))
        self.assertTrue(pump([pub], lambda: pub.channelByName("guest.video")))
        chan = pub.channelByName("guest.video").chanID
        sub = self.connected()
        sub.setMaxFrameBytes(1 << 20)
        got = []
        sub.setGrabDataCallBack(lambda c, data: got.append(len(data)))
        self.assertTrue(pump([sub], lambda: sub.channelByName("guest.video")))
        self.assertTrue(sub.subscribeChannel("guest.video"))
        self.assertTrue(pump([pub, sub], lambda: pub.channelByName("guest.video")
                             .isPublishingEnabled))
        errs = TextIO()
        with redirect_stderr(errs):
            self.assertTrue(pub.publish(chan, bytearray(1000)))
            self.assertTrue(pub.publish(chan, bytearray(4 << 20)))
            self.assertTrue(pump([pub, sub], lambda: "SAT-PROTOCOL" in errs.getvalue()))
            size = len(sub._input.buf)
            # Reconnected and subscribed again by name; the next message arrives.
            self.assertTrue(pump([pub, sub], lambda: sub.isOnline()))
            pump([pub, sub], lambda: False, timeout=0.3)
            self.assertTrue(pub.publish(chan, bytearray(2000)))
            self.assertTrue(pump([pub, sub], lambda: 2000 in got))
        self.assertIn("exceeds the limit of 1048576 bytes", errs.getvalue())
        self.assertEqual(got[0], 1000)
        self.assertNotIn(4 << 20, got)
        self.assertLess(size, 1 << 20)


class Input(unittest.TestCase):
    """FrameInput alone."""

    def test_a_length_over_the_limit_is_refused_when_its_four_bytes_are_in(self):
        inp = FrameInput(maxFrameBytes=1 << 20)
        inp.append(struct.pack("<IB", 0xFFFFFFF0, 0x40))
        self.assertRaises(ProtocolError, inp.next)
        self.assertRaises(ProtocolError, inp.room)
        self.assertEqual(len(inp.buf), MIN_READ)

    def test_frames_split_anywhere_come_whole_and_in_order(self):
        frames = [struct.pack("<IB", len(b) + 1, 0x70 + i % 16) + b
                  for i, b in enumerate([b"x" * k for k in (1, 70000, 3, 200000, 0, 65530)])]
        stream = b"".join(frames)
        for step in (1, 7, 4096, 65536, 100000):
            inp = FrameInput()
            got = []
            for at in range(0, len(stream), step):
                inp.append(stream[at:at + step])
                while True:
                    f = inp.next()
                    if f is None:
                        break
                    got.append(struct.pack("<IB", f[2] - f[1] + 1, f[0]) + inp.body(f[1], f[2]))
            self.assertEqual(got, frames, "step %d" % step)
            self.assertEqual(inp.pending(), 0)

    def test_a_pinned_frame_is_not_moved_by_a_read_meanwhile(self):
        inp = FrameInput()
        inp.append(struct.pack("<IB", 5, 1) + b"abcd" + struct.pack("<I", 100000))
        code, start, end = inp.next()
        buf = inp.buf
        inp.pin()
        inp.append(b"y" * 100001)  # the next frame's rest: it needs room
        self.assertEqual(bytes(buf[start:end]), b"abcd")
        inp.unpin()
        code, start, end = inp.next()
        self.assertEqual(inp.body(start, end), b"y" * 99999)


if __name__ == "__main__":
    unittest.main()
