# SPDX-License-Identifier: Apache-2.0
"""PySketch beside the JavaScript library on one channel (tests/js/hub.test.mjs).

  pysketch_peer.py ADDRESS pub SHORT_NAME HEX...   publishes the payloads in turn, every 20 ms,
                                                   once a subscriber came, until stdin closes
  pysketch_peer.py ADDRESS sub NAME COUNT          prints each payload received as hex, one a
                                                   line, and exits after COUNT of them
"""
from __future__ import print_function

import binascii
import select
import sys
import time

from PySketch.flowsat import FlowSat


def main():
    address, mode, name = sys.argv[1:4]
    sat = FlowSat()
    sat.setLogin("guest", "password")
    chan = {}
    got = []
    sat.setNewChanCallBack(lambda ch: chan.setdefault("id", ch.chanID) if ch.name in
                           ("guest." + name, name) else None)
    sat.setGrabDataCallBack(lambda chanID, data: got.append(bytes(data)))
    if not sat.connect(address):
        print("cannot connect", flush=True)
        return 1
    if mode == "pub":
        payloads = [binascii.unhexlify(h) for h in sys.argv[4:]]
        sat.addStreamingChannel(name=name, mime="application/octet-stream")
        i = 0
        ready = False
        while True:
            sat.tick()
            if "id" in chan and not ready:
                ready = True
                print("ready", flush=True)
            if ready:
                sat.publish(chan["id"], payloads[i % len(payloads)])
                i += 1
            if select.select([sys.stdin], [], [], 0.02)[0] and not sys.stdin.readline():
                return 0
    count = int(sys.argv[4])
    subscribed = False
    deadline = time.time() + 20
    while count > 0 and time.time() < deadline:
        sat.tick()
        if "id" in chan and not subscribed:
            subscribed = True
            sat.subscribeChannel(chan["id"])
            print("subscribed", flush=True)
        while got:
            print(binascii.hexlify(got.pop(0)).decode(), flush=True)
            count -= 1
        time.sleep(0.01)
    return 0 if count <= 0 else 1


if __name__ == "__main__":
    sys.exit(main())
