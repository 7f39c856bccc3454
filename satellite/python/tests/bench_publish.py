# SPDX-License-Identifier: Apache-2.0
"""How long FlowSat.publish() takes for a camera frame, measured, not asserted (not run by CTest).

    SKROBOT_BIN=build/release/bin/skrobot PYTHONPATH=satellite/python \
        /usr/bin/python3 -m tests.bench_publish [rounds]

(from satellite/python). Publishes 640x480x3 (921,600 bytes) and 1920x1080x3 (6,220,800 bytes)
uint8 frames from one FlowSat to a subscriber on a private hub's Unix socket; each round times
publish() alone, then ticks both until the frame has arrived, so that every publish() starts
with nothing waiting. Prints the median and the fastest round, in ms, for the frame given as a
numpy array (where this PySketch takes one), as bytes, and as the caller's frame.tobytes() plus
publish() of those bytes (what a sketch had to write before publish() took arrays).
PYTHONPATH may name another PySketch (an older one, to compare)."""
from __future__ import print_function

import sys

import numpy

from PySketch.elapsedtime import now
from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat

from tests.hubtest import Hub, pump

FRAMES = [("640x480x3", (480, 640, 3)), ("1920x1080x3", (1080, 1920, 3))]


def _sat(hub):
    s = FlowSat()
    s.setLogin("guest", "password")
    s.setAddress(hub.address)
    s.setTickTimer(0.001)
    if not s.connect():
        raise SystemExit("cannot connect to " + hub.address)
    return s


def _median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2]


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    hub = Hub("bench").start()
    try:
        pub, sub = _sat(hub), _sat(hub)
        got = []
        sub.setGrabDataCallBack(lambda chanID, data: got.append(len(data)))
        pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "frames")
        pump([pub, sub], lambda: sub.channelByName("guest.frames") and
             pub.channelByName("guest.frames"))
        sub.subscribeChannel("guest.frames")
        mine = pub.channelByName("guest.frames")
        pump([pub, sub], lambda: mine.isPublishingEnabled)
        for label, shape in FRAMES:
            frame = (numpy.arange(int(numpy.prod(shape)), dtype=numpy.uint32) % 251).astype(
                numpy.uint8).reshape(shape)
            ways = [("bytes", lambda f=frame.tobytes(): pub.publish(mine, f)),
                    ("tobytes()+publish", lambda: pub.publish(mine, frame.tobytes()))]
            try:
                pub.publish(mine, frame)
                pump([pub, sub], lambda: got)
                ways.insert(0, ("ndarray", lambda: pub.publish(mine, frame)))
            except TypeError:
                print("%s: this PySketch does not publish a numpy array" % label)
            del got[:]
            for name, publish in ways:
                times = []
                for _ in range(rounds):
                    t = now()
                    publish()
                    times.append(now() - t)
                    if not pump([pub, sub], lambda: got, timeout=10.0):
                        raise SystemExit("a frame did not arrive")
                    del got[:]
                print("%-12s %-18s median %7.3f ms, fastest %7.3f ms (%d rounds)"
                      % (label, name, _median(times) * 1e3, min(times) * 1e3, rounds))
        pub.close()
        sub.close()
    finally:
        hub.close()


if __name__ == "__main__":
    main()
