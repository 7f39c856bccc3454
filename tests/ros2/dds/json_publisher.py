# SPDX-License-Identifier: Apache-2.0
"""A PySketch satellite that publishes JSON on a channel of its own (ros2_bridge_peers_test):

    json_publisher.py NAME GO_FILE PAYLOAD...

creates guest.NAME (application/json), waits until the hub asks it to publish (a subscriber,
here the bridge once a ROS 2 reader matched) and GO_FILE exists (the test's word that every
reader is ready), publishes each PAYLOAD once in order, prints "published <n>". Python 3 and 2.7."""
from __future__ import print_function

import os
import sys
import time

from PySketch.flowsat import FlowSat


def main(name, go_file, payloads):
    sat = FlowSat()
    sat.setLogin("guest", "password")
    sat.setTickTimer(0.01)
    started = []
    sat.setStartChanPubReqCallBack(lambda ch: started.append(ch.name))
    if not sat.connect():  # ROBOT_ADDRESS
        print("no hub")
        return 2
    if not sat.addStreamingChannel(name=name, mime="application/json"):
        print("cannot add the channel")
        return 2
    deadline = time.time() + 60
    while not (started and os.path.exists(go_file)) and time.time() < deadline:
        sat.tick()
    if not started:
        print("the hub never asked for guest.%s" % name)
        return 1
    sent = 0
    for p in payloads:
        sent += 1 if sat.publish("guest." + name, p) else 0
    end = time.time() + 0.5  # let the frames go out
    while time.time() < end:
        sat.tick()
    print("published %d" % sent)
    return 0 if sent == len(payloads) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2], sys.argv[3:]))
