#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""A satellite that says what its channel carries only after creating it (for
foxglove_bridge.test.mjs): guest.late, created without properties, carries 4x2 rgb8 frames at
20 Hz; each line "props JSON" on stdin sets those keys of its properties (CHAN_SET_PROPS) and
is answered "set". Needs ROBOT_ADDRESS; runs until stdin closes."""
import json
import os
import select
import struct
import sys
import time

from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat

RGB8 = 4
WIDTH, HEIGHT = 4, 2
PIXELS = bytes(range(WIDTH * HEIGHT * 3))


def frame(seq):
    """A media frame: the 32-byte header of docs/channels.md, then the pixels."""
    head = struct.pack("<4sHBBQqHHI", b"SKMF", 32, RGB8, 0, seq, 1700000000123456789,
                       WIDTH, HEIGHT, 0)
    return head + PIXELS


def main():
    sat = FlowSat()
    sat.setLogin("guest", "password")
    sat.setTickTimer(0.01)
    if not sat.connect():
        sys.exit("cannot connect to the hub")
    sat.addStreamingChannel(Flow_T.FT_VIDEO_DATA, Variant_T.T_BYTEARRAY, "late",
                            "application/octet-stream")
    deadline = time.time() + 30
    while time.time() < deadline and sat.channelByName("guest.late") is None:
        sat.tick()
    chan = sat.channelID("guest.late")
    print("ready", flush=True)
    seq, last = 0, 0.0
    stdin = sys.stdin.fileno()
    while True:
        if select.select([stdin], [], [], 0)[0]:
            line = os.read(stdin, 65536).decode()
            if not line:
                return
            for cmd in line.splitlines():
                if cmd.startswith("props "):
                    sat.setChannelProperties(chan, json.loads(cmd[6:]))
                    print("set", flush=True)
        if time.time() - last >= 0.05:
            sat.publish(chan, frame(seq))
            seq, last = seq + 1, time.time()
        sat.tick()


if __name__ == "__main__":
    main()
