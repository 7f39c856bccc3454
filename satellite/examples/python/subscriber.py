#!/usr/bin/env pysketch-executor
# SPDX-License-Identifier: Apache-2.0
# A streaming subscriber: subscribes by name when the channel appears and prints every float.
import argparse
import struct

from PySketch.flowsat import FlowSat
from PySketch.log import msg

parser = argparse.ArgumentParser(description="Prints the floats published on a channel")
parser.add_argument('sketchfile', help='Sketch program file')
parser.add_argument('--user', help='Flow-network username', default='guest')
parser.add_argument('--password', help='Flow-network password', default='password')
parser.add_argument('--channel', help='channel to follow', default='guest.sine')
parser.add_argument('--count', help='stop after this many values (0: never)', type=int,
                    default=0)

sat = FlowSat()
args = None
received = 0


def setup():
    global args
    args = parser.parse_args()
    sat.setLogin(args.user, args.password)
    sat.setTickTimer(0.02)
    sat.setNewChanCallBack(onChannelAdded)
    sat.setDelChanCallBack(onChannelRemoved)
    sat.setGrabDataCallBack(onDataGrabbed)
    return sat.connect()


def loop():
    sat.tick()
    if args.count and received >= args.count:
        return False
    return sat.isConnected()


def close():
    msg("received {} values".format(received))


def onChannelAdded(ch):
    if ch.name == args.channel:
        msg("found {} (id {}): subscribing".format(ch.name, ch.chanID))
        sat.subscribeChannel(ch.chanID)


def onChannelRemoved(ch):
    if ch.name == args.channel:
        msg("{} went away".format(ch.name))


def onDataGrabbed(chanID, data):
    global received
    ch = sat.channelByID(chanID)
    for value in struct.unpack("<%df" % (len(data) // 4), data):
        received += 1
        print("{}: {:.4f}".format(ch.name if ch else chanID, value))
