# SPDX-License-Identifier: Apache-2.0
"""The Python twin of satellite/cpp/tests/paths_publisher.cpp: a PySketch channel owner that offers
physical-mode paths (PySketch/flowowner.py), driven by the same command line and the same
commands on stdin, so that test_paths.py's hub tests run against either owner.

    python3 -m tests.paths_publisher ADDRESS CHANNEL KINDS SLOT_BYTES [RATE_HZ [COUNT]]

Its messages: bytes 0-7 the message number (u64, little-endian, from 1), byte i >= 8
(number + i) & 0xFF. Commands (answers on stdout, one a line, flushed):
  pub N SIZE   N messages at once (publish: copied into a ring slot)   -> "published <last>"
  zc N SIZE    the same, each filled in a ring slot in place (beginPublish / commitPublish)
  slow N SIZE  N messages, one per loop (RATE_HZ), then                 -> "published <last>"
  ts N SIZE    the same, bytes 8-15 CLOCK_MONOTONIC in ns when published
  frames N W H N bgr8 media frames of W x H, one per loop, each built in place with numpy
               (beginPublish, mediaframe.frame_slot): header seq = the message number, pixel
               byte i = (i + number) & 0xFF; then                       -> "published <last>"
  reset        resetPaths()                                            -> "reset"
  stats        -> "stats served_shm=<n> served_direct=<n>"
  quit         exits 0
It prints "ready <id>" when its channel is created and "subscribed" at each EV_START_PUBLISH.
"""
from __future__ import print_function

import os
import struct
import sys
import time

from PySketch.flowproto import PATH_DIRECT, PATH_SHM
from PySketch.flowsat import FlowSat


def say(line):
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def fill(buf, size, number):
    """The pattern of message `number` into buf[:size] (a writable buffer)."""
    head = struct.pack("<Q", number)[:size]
    buf[:len(head)] = head
    if size > 8:
        base = (number + 8) & 0xFF
        pattern = bytes(bytearray((base + i) & 0xFF for i in range(256)))
        rest = size - 8
        reps = pattern * (rest // 256 + 1)
        buf[8:size] = reps[:rest]


class Publisher(object):
    def __init__(self, argv):
        address, self.channel, kinds, slot = argv[:4]
        rate = float(argv[4]) if len(argv) > 4 else 200.0
        self.count = int(argv[5]) if len(argv) > 5 else 0
        paths = {"shm": PATH_SHM, "direct": PATH_DIRECT, "both": PATH_SHM | PATH_DIRECT,
                 "none": 0}[kinds]
        self.sat = FlowSat()
        self.sat.setLogin(os.environ.get("ROBOT_USER", "guest"),
                          os.environ.get("ROBOT_PASSWORD", "password"))
        self.sat.setAddress(address)
        self.sat.setTickTimer(1.0 / rate)
        self.sat.setNewChanCallBack(self.onNewChannel)
        self.sat.setStartChanPubReqCallBack(self.onStart)
        self.number = 0
        self.slowLeft = 0
        self.slowSize = 64
        self.stamp = False
        self.frames = None          # (left, width, height) of a `frames` command
        self.counted = False
        self.pending = b""
        self.running = True
        self.full = "%s.%s" % (os.environ.get("ROBOT_USER", "guest"), self.channel)
        if not self.sat.addStreamingChannel(name=self.channel, paths=paths, ringSlots=4,
                                            slotBytes=int(slot), ringReaders=8):
            say("error addStreamingChannel")

    def onNewChannel(self, ch):
        if ch.name == self.full and ch.isOwned:
            say("ready %d" % ch.chanID)

    def onStart(self, ch):
        say("subscribed")
        if self.count > 0 and not self.counted:
            self.counted = True
            self.slowLeft, self.slowSize = self.count, 64

    def publishOne(self, size, stamp=False):
        self.number += 1
        buf = bytearray(size)
        fill(buf, size, self.number)
        if stamp and size >= 16:
            struct.pack_into("<q", buf, 8, int(time.monotonic() * 1e9))
        self.sat.publish(self.full, buf)

    def publishFrame(self):
        import numpy
        from PySketch import mediaframe
        left, w, h = self.frames
        view = self.sat.beginPublish(self.full)
        self.number += 1
        img, size = mediaframe.frame_slot(view, "bgr8", w, h, seq=self.number)
        base = numpy.arange(w * h * 3, dtype=numpy.uint32).astype(numpy.uint8).reshape(h, w, 3)
        numpy.add(base, numpy.uint8(self.number & 0xFF), out=img)  # wraps: (i + n) & 0xFF
        del img
        self.sat.commitPublish(self.full, size, self.number)
        self.frames = (left - 1, w, h) if left > 1 else None
        if self.frames is None:
            say("published %d" % self.number)

    def command(self, line):
        parts = line.split()
        if not parts:
            return
        what = parts[0]
        n = int(parts[1]) if len(parts) > 1 else 0
        size = max(8, int(parts[2]) if len(parts) > 2 else 8)
        if what == "pub":
            for _ in range(n):
                self.publishOne(size)
            say("published %d" % self.number)
        elif what == "zc":
            for _ in range(n):
                view = self.sat.beginPublish(self.full)
                if view is None or len(view) < size:
                    return say("zc-failed")
                self.number += 1
                fill(view, size, self.number)
                if not self.sat.commitPublish(self.full, size, self.number):
                    return say("zc-failed")
            say("published %d" % self.number)
        elif what in ("slow", "ts"):
            self.slowLeft, self.slowSize, self.stamp = n, size, what == "ts"
        elif what == "frames":
            self.frames = (n, int(parts[2]), int(parts[3]))
        elif what == "reset":
            self.sat.resetPaths()
            say("reset")
        elif what == "stats":
            st = self.sat.pathStats()
            say("stats served_shm=%d served_direct=%d" % (st["served_shm"], st["served_direct"]))
        elif what == "quit":
            self.running = False

    def readCommands(self):
        while True:
            try:
                got = os.read(0, 4096)
            except (OSError, IOError):
                break  # nothing now
            if not got:
                self.running = False  # the test went away
                break
            self.pending += got
        while b"\n" in self.pending:
            line, self.pending = self.pending.split(b"\n", 1)
            self.command(line.decode("utf-8", "replace"))

    def run(self):
        import fcntl
        fcntl.fcntl(0, fcntl.F_SETFL, fcntl.fcntl(0, fcntl.F_GETFL) | os.O_NONBLOCK)
        self.sat.connect()
        while self.running:
            self.readCommands()
            if self.slowLeft > 0:
                self.publishOne(self.slowSize, self.stamp)
                self.slowLeft -= 1
                if self.slowLeft == 0:
                    say("published %d" % self.number)
            if self.frames:
                self.publishFrame()
            self.sat.tick()
        self.sat.close()
        return 0


if __name__ == "__main__":
    if len(sys.argv) < 5:
        sys.stderr.write("usage: %s ADDRESS CHANNEL shm|direct|both|none SLOT_BYTES "
                         "[RATE_HZ [COUNT]]\n" % sys.argv[0])
        sys.exit(2)
    sys.exit(Publisher(sys.argv[1:]).run())
