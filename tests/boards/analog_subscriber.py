# SPDX-License-Identifier: Apache-2.0
"""A Python satellite that reads a board's channel (board_hub_test): subscribes to CHANNEL when it
appears, counts COUNT payloads, prints "<n> values of <sizes> bytes". Python 3 and 2.7."""
from __future__ import print_function

import sys
import time

from PySketch.flowsat import FlowSat


def main(name, want):
    sat = FlowSat()
    sat.setLogin("guest", "password")
    sat.setTickTimer(0.01)
    got = []

    def on_new(ch):
        if ch.name == name:
            sat.subscribeChannel(ch.chanID)

    sat.setNewChanCallBack(on_new)
    sat.setGrabDataCallBack(lambda chan_id, data: got.append(len(data)))
    if not sat.connect():  # ROBOT_ADDRESS
        print("no hub")
        return 2
    deadline = time.time() + 25
    while len(got) < want and time.time() < deadline:
        sat.tick()
    sizes = ",".join(sorted(set(str(n) for n in got)))
    print("%d values of %s bytes" % (len(got), sizes))
    return 0 if len(got) >= want else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2])))
