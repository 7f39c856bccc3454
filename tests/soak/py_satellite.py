# SPDX-License-Identifier: Apache-2.0
"""A Python satellite for the soak test (tests/soak/soak.py), with the roles of
soak_satellite.cpp and the same lines on stdout. It reconnects by itself (PySketch's FlowSat).

    ROBOT_ADDRESS=local:/tmp/<app> python3 py_satellite.py ROLE NAME [TARGET]
"""
import sys
import time

from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat


def say(line):
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def main():
    role, name = sys.argv[1], sys.argv[2]
    target = sys.argv[3] if len(sys.argv) > 3 else None
    slot, base = "", 0
    if role == "db":  # TARGET is SLOT:BASE, as for soak_satellite
        slot, base = target.split(":")[0], int(target.split(":")[1])
    sat = FlowSat()
    sat.setLogin("guest", "password")
    sat.setNodeName("soak-py-%s-%s" % (role, name))
    sat.setTickTimer(0.01)
    if role == "sub":
        sat.setGrabDataCallBack(lambda chanID, data: say("DATA"))
    elif role == "svc":
        sat.setRequestCallBack(lambda chanID, h, cmd, v: sat.sendServiceResponse(chanID, h, v))
    elif role == "call":
        sat.setResponseCallBack(lambda chanID, v: say("RESP"))
    while not sat.connect():  # the hub may be restarting
        time.sleep(0.2)
    if role == "pub":
        sat.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, name,
                                "application/octet-stream")
    elif role == "svc":
        sat.addServiceChannel(name)
    elif role == "sub":
        sat.subscribeChannel(target)
    say("CONNECTED")
    sync = None
    n = 0
    last = 0.0
    payload = b"p" * 64
    while True:
        sat.tick()
        now = time.time()
        if now - last < 0.05:
            continue
        last = now
        if not sat.isOnline():
            if sync is not None:
                sync.close()
                sync = None
            continue
        if role == "pub":
            ch = sat.channelByName("guest." + name)
            if ch is not None and ch.isPublishingEnabled:
                sat.publish(ch.chanID, payload)
        elif role == "call":
            sat.sendServiceRequest(target, "echo", n)
            n += 1
        elif role == "db":
            if sync is None:
                sync = sat.newSyncClient(timeout=5.0)
                if not sync.isConnected() or not sync.setCurrentDbName("soak"):
                    sync.close()
                    sync = None
                    continue
            key = "%s-%d" % (slot, n % 50)
            if sync.setVariable(key, base + n):
                say("ACK %s %d" % (key, base + n))
                n += 1
            else:
                sync.close()
                sync = None


if __name__ == "__main__":
    main()
