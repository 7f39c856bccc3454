# SPDX-License-Identifier: Apache-2.0
"""A subscription's own queue size (subscribeChannel's queueBytes, FlowProtocol 1.13): a
subscriber that reads late loses nothing with a queue that holds the burst, where the hub's
default drops the oldest; a request above server.subscriber_queue_max_bytes is clamped and
reported to the error callback, and the subscription stands."""
from __future__ import print_function

import struct
import unittest

from PySketch.flowproto import Error_T, Flow_T, Variant_T

from tests.hubtest import HubTestCase, pump

FRAME = 100 * 1024   # a large frame
FRAMES = 40          # 4 MB: four times the default queue below
DEFAULT = 1 << 20    # server.subscriber_queue_bytes
CAP = 8 << 20        # server.subscriber_queue_max_bytes


class Queue(HubTestCase):
    server = {"subscriber_queue_bytes": DEFAULT, "subscriber_queue_max_bytes": CAP}

    def subscriber(self, queueBytes=None):
        """A satellite subscribed to guest.video; returns it and the frame numbers it gets."""
        s = self.connected()
        got = []
        s.setGrabDataCallBack(lambda chanID, data: got.append(struct.unpack("<i", bytes(data[:4]))[0]))
        self.assertTrue(pump([s], lambda: s.channelByName("guest.video")))
        if queueBytes is None:
            self.assertTrue(s.subscribeChannel("guest.video"))
        else:
            self.assertTrue(s.subscribeChannel("guest.video", queueBytes=queueBytes))
        return s, got

    def publisher(self):
        pub = self.connected()
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "video"))
        self.assertTrue(pump([pub], lambda: pub.channelByName("guest.video")))
        return pub, pub.channelByName("guest.video")

    def burst(self, pub, mine, watcher, seen):
        """FRAMES numbered frames; returns once `watcher` (which reads) has them all: by then
        the hub has queued every one for the others."""
        payload = bytearray(FRAME)
        for i in range(FRAMES):
            struct.pack_into("<i", payload, 0, i)
            self.assertTrue(pub.publish(mine.chanID, payload))
            pub.tick()
        self.assertTrue(pump([pub, watcher], lambda: len(seen) >= FRAMES),
                        "the watcher got %d of %d" % (len(seen), FRAMES))

    def test_a_bigger_queue_loses_nothing_where_the_default_drops(self):
        pub, mine = self.publisher()
        plain, plainGot = self.subscriber()
        big, bigGot = self.subscriber(queueBytes=6 << 20)
        watcher, seen = self.subscriber(queueBytes=CAP)
        self.assertTrue(pump([pub, plain, big, watcher], lambda: mine.isPublishingEnabled))
        pump([plain, big, watcher], lambda: False, timeout=0.2)  # every SUBSCRIBE handled
        self.burst(pub, mine, watcher, seen)
        # Now the two late readers read.
        self.assertTrue(pump([big, plain], lambda: len(bigGot) >= FRAMES and
                             plainGot and plainGot[-1] == FRAMES - 1))
        self.assertEqual(bigGot, list(range(FRAMES)), "the larger queue lost frames")
        self.assertLess(len(plainGot), FRAMES, "the default queue dropped nothing")
        self.assertEqual(plainGot[-1], FRAMES - 1)  # newest wins

    def test_a_request_above_the_cap_is_clamped_and_reported(self):
        pub, mine = self.publisher()
        errors = []
        greedy = self.connected()
        greedy.setErrorCallBack(lambda e: errors.append(e))
        got = []
        greedy.setGrabDataCallBack(lambda chanID, data: got.append(len(data)))
        self.assertTrue(pump([greedy], lambda: greedy.channelByName("guest.video")))
        self.assertTrue(greedy.subscribeChannel("guest.video", queueBytes=1 << 30))
        self.assertTrue(pump([pub, greedy], lambda: errors))
        self.assertEqual(errors[0].code, Error_T.limit_exceeded)
        self.assertEqual(errors[0].command, "SUBSCRIBE_QUEUE")
        self.assertEqual(errors[0].channel, "guest.video")
        self.assertIn(str(CAP), errors[0].message)
        # Subscribed all the same.
        self.assertTrue(pump([pub, greedy], lambda: mine.isPublishingEnabled))
        self.assertTrue(pub.publish(mine.chanID, b"frame"))
        self.assertTrue(pump([pub, greedy], lambda: got))


if __name__ == "__main__":
    unittest.main()
