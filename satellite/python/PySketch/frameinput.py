# SPDX-License-Identifier: Apache-2.0
"""FrameInput: a connection's input, read with socket.recv_into into one bytearray that is reused
for every read, and split into frames where they lie (no copy per read, per frame or per message).

The buffer grows to the largest frame received (plus one read), never beyond the frame limit: a
length over the limit (or 0) is refused as soon as its 4 bytes are in, before anything is
allocated for it. It is never resized in place, only replaced by a larger one, and bytes are
moved to its start only while nobody looks at them (pin()), so a memoryview of a frame handed to
a callback stays valid until the callback returns, and a view kept longer (a slice, a numpy
array) never stops the reading: it shows whatever later bytes come to that place.

Python 2.7 and 3 alike (recv_into exists in both; TLS sockets included).
"""
from __future__ import print_function, division, absolute_import

import struct

from PySketch.flowproto import ProtocolError

DEFAULT_MAX_FRAME_BYTES = 16 * 1024 * 1024  # as the C++ library (kDefaultMaxFrameBytes)
MIN_READ = 65536                            # the least room a read is given
_LENGTH = struct.Struct("<I")


class FrameInput(object):
    def __init__(self, maxFrameBytes=DEFAULT_MAX_FRAME_BYTES):
        self.maxFrameBytes = maxFrameBytes
        self.buf = bytearray(MIN_READ)
        self._r = 0       # where the next frame starts
        self._w = 0       # where the bytes received end
        self._pins = 0    # callbacks looking at frames in place

    def clear(self):
        """Forgets what was received (a new connection); a pinned buffer is left to its views."""
        if self._pins:
            self.buf = bytearray(MIN_READ)
        self._r = self._w = 0

    def pending(self):
        return self._w - self._r

    def _announced(self):
        """The length of the frame at the read position once its 4 bytes are in, else None;
        ProtocolError for 0 or a length over the limit."""
        if self._w - self._r < 4:
            return None
        n = _LENGTH.unpack_from(self.buf, self._r)[0]
        if n == 0:
            raise ProtocolError("frame length 0 (a frame holds at least its code)")
        if n > self.maxFrameBytes:
            raise ProtocolError("frame length %d exceeds the limit of %d bytes"
                                % (n, self.maxFrameBytes))
        return n

    def room(self):
        """Makes room for the next read and returns how many bytes it may take: at least what
        the frame that has begun still lacks, and MIN_READ where moving what waits to the start
        of the buffer gives that much."""
        r, w = self._r, self._w
        if r == w and not self._pins:
            r = w = self._r = self._w = 0
        n = self._announced()
        have = w - r
        lacks = (4 + n if n is not None else 4) - have  # <= 0: whole frames wait (held)
        good = max(lacks, MIN_READ)
        enough = max(lacks, 1)
        cap = len(self.buf)
        for wanted in (good, enough):
            if cap - w >= wanted:
                return cap - w
            if cap - have >= wanted and not self._pins:
                self.buf[0:have] = self.buf[r:w]  # same size: allowed while views are kept
                self._r, self._w = 0, have
                return cap - have
        # A larger buffer: the frame in progress and a read, or double while whole frames wait
        # (held for tick() during connect()).
        size = have + good if lacks > 0 else 2 * cap
        grown = bytearray(size)
        grown[0:have] = self.buf[r:w]
        self.buf, self._r, self._w = grown, 0, have
        return size - have

    def recvInto(self, sock):
        """One read from `sock` into the room after the bytes received: the count, 0 when the
        peer closed. Socket errors (EAGAIN included) are the caller's."""
        room = self.room()
        n = sock.recv_into(memoryview(self.buf)[self._w:self._w + room], room)
        self._w += n
        return n

    def append(self, data):
        """Adds bytes received another way (a test feeding its own frames)."""
        data = bytes(data)
        while data:
            room = self.room()
            part, data = data[:room], data[room:]
            self.buf[self._w:self._w + len(part)] = part
            self._w += len(part)

    def next(self):
        """(code, start, end) of the next complete frame, consumed: its body is buf[start:end];
        None when it is not all in. ProtocolError for a length of 0 or over the limit."""
        n = self._announced()
        if n is None or self._w - self._r < 4 + n:
            return None
        start = self._r
        self._r = start + 4 + n
        return self.buf[start + 4], start + 5, start + 4 + n

    def body(self, start, end):
        """A frame's body as bytes (a copy, for frames other than data)."""
        return bytes(self.buf[start:end])

    def pin(self):
        """While pinned (callbacks look at frames in place), nothing received is moved: room
        comes from a new buffer."""
        self._pins += 1

    def unpin(self):
        self._pins -= 1
