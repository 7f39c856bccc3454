#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Traffic for the network page's browser test (network_browser.test.mjs), as user guest:
--channels JSON channels (guest.c000...) at 1 Hz, a JPEG camera, gray and rgb8 frames, audio, face
detections whose properties name the camera as their source, and a second flow subscribed to
the first ten JSON channels. Needs ROBOT_ADDRESS; runs until killed."""
import argparse
import math
import struct
import sys
import time

from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat

JPEG, Y8, PCM, RGB8 = 1, 2, 3, 4


def frame(fmt, seq, a, b, rate, payload):
    """A media frame: the 32-byte header of docs/channels.md, then the payload."""
    head = struct.pack("<4sHBBQqHHI", b"SKMF", 32, fmt, 0, seq, int(time.time() * 1e9), a, b, rate)
    return head + payload


def jpegSize(data):
    """Width and height from a JPEG's start-of-frame marker."""
    i = 2
    while i + 9 < len(data):
        marker, length = data[i + 1], struct.unpack(">H", data[i + 2:i + 4])[0]
        if marker in (0xC0, 0xC1, 0xC2):
            h, w = struct.unpack(">HH", data[i + 5:i + 9])
            return w, h
        i += 2 + length
    raise ValueError("no start-of-frame marker")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--channels", type=int, default=200)
    ap.add_argument("--jpeg", required=True)
    args = ap.parse_args()
    with open(args.jpeg, "rb") as f:
        jpeg = f.read()
    width, height = jpegSize(jpeg)

    owner, listener = FlowSat(), FlowSat()
    for sat in (owner, listener):
        sat.setLogin("guest", "password")
        sat.setTickTimer(0.02)
        if not sat.connect():
            sys.exit("cannot connect to the hub")
    names = ["c%03d" % i for i in range(args.channels)]
    for n in names:
        owner.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_STRING, n, "application/json",
                                  props={"index": int(n[1:])})
    owner.addStreamingChannel(Flow_T.FT_VIDEO_DATA, Variant_T.T_BYTEARRAY, "camera", "image/jpeg")
    owner.addStreamingChannel(Flow_T.FT_VIDEO_DATA, Variant_T.T_BYTEARRAY, "gray", "image/x-gray")
    owner.addStreamingChannel(Flow_T.FT_VIDEO_DATA, Variant_T.T_BYTEARRAY, "colour",
                              "application/octet-stream", props={"encoding": "rgb8"})
    owner.addStreamingChannel(Flow_T.FT_AUDIO_DATA, Variant_T.T_BYTEARRAY, "audio", "audio/L16")
    owner.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_STRING, "faces", "application/json",
                              props={"source": "guest.camera"})
    deadline = time.time() + 30
    while time.time() < deadline and owner.channelByName("guest.faces") is None:
        owner.tick()
        listener.tick()
    for n in names[:10]:
        listener.subscribeChannel("guest." + n)
    ids = dict((n, owner.channelID("guest." + n)) for n in names + ["camera", "gray", "colour", "audio", "faces"])
    print("ready", flush=True)

    gray = bytes(((x + y) * 2) & 0xFF for y in range(48) for x in range(64))
    colour = bytes(v for y in range(12) for x in range(16) for v in (x * 4, y * 5, 100))
    rate, seq, tick = 22050, 0, 0
    while True:
        now = time.time()
        if tick % 50 == 0:  # each second
            for n in names:
                owner.publish(ids[n], ('{"i": %d, "t": %.3f}' % (int(n[1:]), now)).encode())
        if tick % 10 == 0:  # 5 Hz
            owner.publish(ids["camera"], frame(JPEG, tick, width, height, 0, jpeg))
            owner.publish(ids["gray"], frame(Y8, tick, 64, 48, 0, gray))
            owner.publish(ids["colour"], frame(RGB8, tick, 16, 12, 0, colour))
            face = {"seq": tick, "width": width, "height": height,
                    "faces": [{"x": width // 4, "y": height // 4, "w": width // 3,
                               "h": height // 3, "score": 0.9}]}
            owner.publish(ids["faces"], (str(face).replace("'", '"')).encode())
        if tick % 5 == 0:  # 10 Hz, a 440 Hz tone at -12 dBFS
            n = rate // 10
            pcm = struct.pack("<%dh" % n, *(int(8000 * math.sin(2 * math.pi * 440 * (seq + i) / rate))
                                             for i in range(n)))
            owner.publish(ids["audio"], frame(PCM, seq, 1, 0, rate, pcm))
            seq += n
        tick += 1
        owner.tick()
        listener.tick()


if __name__ == "__main__":
    main()
