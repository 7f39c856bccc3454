#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Video frames in Python: bgr8 media frames (PySketch/mediaframe.py) of 640x480 and 1920x1080,
at 30 Hz and as fast as the publisher can, Python -> Python over the relay and over shared
memory, against the C++ pair (python_frames_peer) measured in the same run as the baseline.

    python_frames.py [--quick]       SKROBOT_BIN, PYTHON_FRAMES_PEER, PYTHONPATH (satellite/python)

Each row is a publisher process and a subscriber process on one hub. Per row: frames/s the
subscriber got, skips (frames missing before the last it got: the frame's seq; newest-wins on
shared memory, the hub's drops on the relay), drops (published after the last it got), latency p50/p99
(from the frame's capture_ns, CLOCK_MONOTONIC when it was published, to the subscriber's
callback), the publisher's CPU per frame (its own user + system time from the first frame to the
last) and Python's CPU per frame against the C++ pair's. A relayed subscriber asks for a queue of
four frames (subscribeChannel(name, queueBytes=...)). The frames are made once (make_frame) and
their seq and capture_ns written in place for each one; on shared memory the publisher copies
the frame into its slot (as a camera would fill it), on the relay publish() sends it.

Short by default (3 s of frames per row at 30 Hz, 150 frames as fast as possible); --quick, the
CTest bench.python_frames_quick, 0.5 s and 30; PYTHON_FRAMES_SECONDS for longer runs.
Python shared memory needs PySketch as a channel owner (beginPublish/commitPublish): without it
the row says "python shm: not available in this build".
"""
from __future__ import print_function

import os
import struct
import subprocess
import sys
import time

SEQ_CAPTURE = struct.Struct("<Qq")  # the media header's seq and capture_ns, at offset 8
NOT_AVAILABLE = 3                   # a Python publisher's exit status: no shm owner here


def now_ns():
    return time.monotonic_ns()  # CLOCK_MONOTONIC, as the C++ peer's skr::monotonicNs()


def cpu_ns():
    t = os.times()
    return int((t[0] + t[1]) * 1e9)


# --- the Python publisher and subscriber (this file, run as a child) ---------------------------

def publisher(address, channel, width, height, rate, count, path):
    import numpy
    from PySketch import mediaframe
    from PySketch.flowsat import PATH_DIRECT, PATH_SHM, FlowSat
    sat = FlowSat()
    sat.setAddress(address)
    sat.setTickTimer(1.0 / rate if rate else 0.0002)
    if path == "shm" and not hasattr(sat, "beginPublish"):
        print("python shm: not available in this build")
        return NOT_AVAILABLE
    if not sat.connect():
        return 1
    img = numpy.full((height, width, 3), 0x80, dtype=numpy.uint8)
    frame = mediaframe.make_frame(img, "bgr8")
    props = mediaframe.channel_properties("bgr8", width=width, height=height, fps=rate or 30)
    mime = mediaframe.mime_for("bgr8")
    if path == "shm":
        sat.addStreamingChannel(name=channel, mime=mime, props=props,
                                paths=PATH_SHM | PATH_DIRECT, ringSlots=4,
                                slotBytes=len(frame))
    else:
        sat.addStreamingChannel(name=channel, mime=mime, props=props)
    name = "%s.%s" % (sat.userName(), channel)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        ch = sat.channelByName(name)
        if ch is not None and ch.isPublishingEnabled:
            break
        sat.tick()
    else:
        return 1
    if path == "shm":  # as the C++ peer: the subscriber's path may come 1 s after it asked
        end = time.monotonic() + 3
        while time.monotonic() < end and not sat.pathStats().get("served_shm"):
            sat.tick()
    chan = ch.chanID
    sent = 0
    cpu0 = cpu_ns()
    while sent < count:
        if path == "shm":
            view = sat.beginPublish(chan)
            if view is not None and len(view) >= len(frame):
                view[:len(frame)] = frame
                SEQ_CAPTURE.pack_into(view, 8, sent + 1, now_ns())
                if sat.commitPublish(chan, len(frame), 0):
                    sent += 1
        else:
            SEQ_CAPTURE.pack_into(frame, 8, sent + 1, now_ns())
            if sat.publish(chan, frame):
                sent += 1
        sat.tick()
    cpu = cpu_ns() - cpu0
    end = time.monotonic() + 0.3  # as the C++ peer: the readers take the last frames first
    while (sat._outbuf and sat.isOnline()) or time.monotonic() < end:
        sat.tick()
    print("published %d cpu_ns %d" % (sent, cpu))
    sys.stdout.flush()
    sat.close()
    return 0


def subscriber(address, name, count, path, queue, seconds):
    from PySketch import mediaframe
    from PySketch.flowsat import PATH_SHM, FlowSat
    sat = FlowSat()
    sat.setAddress(address)
    sat.setTickTimer(0.001)
    lat, state = [], {"last": 0, "skips": 0, "first_ns": 0, "last_ns": 0}

    def onView(chanID, view):
        t = now_ns()
        f = mediaframe.parse_frame(view)   # what a subscriber does: the header, then
        f.array()                          # the pixels as an (h, w, 3) array, no copy
        if f.seq > state["last"] + 1:  # seq counts from 1
            state["skips"] += f.seq - state["last"] - 1
        state["last"] = f.seq
        state["first_ns"] = state["first_ns"] or t
        state["last_ns"] = t
        lat.append(t - f.capture_ns)

    sat.setGrabDataViewCallBack(onView)
    if not sat.connect():
        return 1
    if path == "shm":
        sat.usePaths(name, PATH_SHM)
    sat.subscribeChannel(name, queueBytes=queue)
    end = time.monotonic() + seconds
    while state["last"] < count and time.monotonic() < end:
        sat.tick()
    print("received %d skips %d span_ns %d lat_ns %s" % (
        len(lat), state["skips"], state["last_ns"] - state["first_ns"],
        " ".join(str(x) for x in lat)))
    sys.stdout.flush()
    sat.close()
    return 0


# --- the driver --------------------------------------------------------------------------------

def percentile(values, p):
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100.0 * (len(s) - 1))))]


def run_row(hub, peer, lang, width, height, rate, path, count, n):
    channel = "frames%d" % n
    name = "guest." + channel
    frame_bytes = 32 + width * height * 3
    env = dict(hub.env(ROBOT_USER="guest", ROBOT_PASSWORD="password"))
    me = [sys.executable, os.path.abspath(__file__)]
    seconds = count / float(rate or 60) + 5
    if lang == "C++":
        sub_cmd = [peer, "sub", hub.address, name, str(count), path, str(4 * frame_bytes),
                   str(seconds)]
        pub_cmd = [peer, "pub", hub.address, channel, str(width), str(height), str(rate),
                   str(count), path]
    else:
        sub_cmd = me + ["sub", hub.address, name, str(count), path, str(4 * frame_bytes),
                        str(seconds)]
        pub_cmd = me + ["pub", hub.address, channel, str(width), str(height), str(rate),
                        str(count), path]
    sub = subprocess.Popen(sub_cmd, env=env, stdout=subprocess.PIPE, universal_newlines=True)
    pub = subprocess.Popen(pub_cmd, env=env, stdout=subprocess.PIPE, universal_newlines=True)
    pub_out = pub.communicate(timeout=seconds + 30)[0]
    if pub.returncode == NOT_AVAILABLE:
        sub.kill()
        sub.communicate()
        return {"na": pub_out.strip()}
    sub_out = sub.communicate(timeout=seconds + 30)[0]
    p = [l for l in pub_out.splitlines() if l.startswith("published")]
    s = [l for l in sub_out.splitlines() if l.startswith("received")]
    if pub.returncode != 0 or sub.returncode != 0 or not p or not s:
        raise SystemExit("FAIL: %s %s %dx%d: publisher %s %r, subscriber %s %r" % (
            lang, path, width, height, pub.returncode, pub_out[-300:], sub.returncode,
            sub_out[-300:]))
    pw, sw = p[0].split(), s[0].split()
    published, cpu = int(pw[1]), int(pw[3])
    received, skips = int(sw[1]), int(sw[3])
    span = int(sw[5]) / 1e9
    lat = [int(x) for x in sw[7:]]
    return {"fps": (received - 1) / span if span > 0 else float("nan"),
            "published": published, "received": received, "skips": skips,
            "drops": published - received - skips, "p50": percentile(lat, 50) / 1e6,
            "p99": percentile(lat, 99) / 1e6, "cpu": cpu / float(max(published, 1)) / 1e6}


def main():
    quick = "--quick" in sys.argv[1:]
    seconds = float(os.environ.get("PYTHON_FRAMES_SECONDS", "0.5" if quick else "3"))
    peer = os.environ.get("PYTHON_FRAMES_PEER")
    if not peer or not os.environ.get("SKROBOT_BIN"):
        print("set SKROBOT_BIN and PYTHON_FRAMES_PEER (ctest does)")
        return 2
    from tests.hubtest import Hub  # satellite/python on PYTHONPATH; the children's PySketch
    hub = Hub("frames", server={"subscriber_queue_max_bytes": 64 << 20}).start()
    results = []
    n = 0
    try:
        print("%-9s %-5s %-6s %-4s %8s %6s %6s %9s %9s %11s %8s" % (
            "size", "rate", "path", "pair", "frames/s", "skips", "drops", "p50 ms", "p99 ms",
            "CPU/frame", "py/C++"))
        only = os.environ.get("PYTHON_FRAMES_ONLY", "")  # e.g. "1920x1080 max relay"
        for width, height in ((640, 480), (1920, 1080)):
            for rate in (30, 0):
                count = int(seconds * rate) if rate else int(seconds * 300)
                for path in ("relay", "shm"):
                    row = {}
                    if only not in "%dx%d %s %s" % (width, height, "%dHz" % rate if rate
                                                     else "max", path):
                        continue
                    for lang in ("C++", "Python"):
                        n += 1
                        row[lang] = run_row(hub, peer, lang, width, height, rate, path,
                                            count, n)
                    for lang in ("C++", "Python"):
                        r = row[lang]
                        label = "%-9s %-5s %-6s %-4s" % ("%dx%d" % (width, height),
                                                         "%dHz" % rate if rate else "max",
                                                         path, "py" if lang == "Python" else
                                                         "C++")
                        if "na" in r:
                            print("%s %s" % (label, r["na"]))
                            continue
                        fps = r["fps"]
                        ratio = ""
                        if lang == "Python" and "na" not in row["C++"]:
                            ratio = "%.2fx" % (r["cpu"] / max(row["C++"]["cpu"], 1e-9))
                        print("%s %8.1f %6d %6d %9.2f %9.2f %8.2f ms %8s" % (
                            label, fps, r["skips"], r["drops"], r["p50"], r["p99"], r["cpu"],
                            ratio))
                        results.append(((width, height, rate, path, lang), r))
                    sys.stdout.flush()
    finally:
        hub.close()
    targets(dict(results))
    return 0


def targets(r):
    """Issue 42's targets for 1080p at 30 Hz, against this run."""
    def line(key, what, ok):
        print("target: %s: %s" % (what, "met" if ok else "missed") if key in r else
              "target: %s: not measured" % what)
    shm, cshm = r.get((1920, 1080, 30, "shm", "Python")), r.get((1920, 1080, 30, "shm", "C++"))
    key = (1920, 1080, 30, "shm", "Python")
    if shm is not None and "na" not in shm and cshm is not None:
        line(key, "Python shm 1080p30 p99 < 5 ms (%.2f ms)" % shm["p99"], shm["p99"] < 5)
        line(key, "Python shm 1080p30 no skip (%d)" % shm["skips"], shm["skips"] == 0)
        line(key, "Python shm 1080p30 CPU per frame < 1.5x C++ (%.2fx)" % (
            shm["cpu"] / max(cshm["cpu"], 1e-9)), shm["cpu"] < 1.5 * cshm["cpu"])
    else:
        print("target: Python shm 1080p30: not measured (no Python owner of paths)")
    key = (1920, 1080, 30, "relay", "Python")
    relay = r.get(key)
    if relay is not None:
        line(key, "Python relay 1080p30 with a queue of 4 frames, no drop or skip (%d, %d)" % (
            relay["drops"], relay["skips"]), relay["drops"] == 0 and relay["skips"] == 0)


if __name__ == "__main__":
    role = sys.argv[1] if len(sys.argv) > 1 else ""
    if role == "pub":
        a = sys.argv[2:]
        sys.exit(publisher(a[0], a[1], int(a[2]), int(a[3]), float(a[4]), int(a[5]), a[6]))
    if role == "sub":
        a = sys.argv[2:]
        sys.exit(subscriber(a[0], a[1], int(a[2]), a[3], int(a[4]), float(a[5])))
    sys.exit(main())
