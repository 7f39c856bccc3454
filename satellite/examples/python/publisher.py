#!/usr/bin/env pysketch-executor
# SPDX-License-Identifier: Apache-2.0
# A streaming publisher: a sine wave as float32 values on "<user>.sine", produced only while
# someone subscribes (the hub tells the owner about its first and last subscriber).
import argparse
import math

from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat
from PySketch.elapsedtime import ElapsedTime
from PySketch.log import msg

parser = argparse.ArgumentParser(description="Publishes a sine wave while someone listens")
parser.add_argument('sketchfile', help='Sketch program file')
parser.add_argument('--user', help='Flow-network username', default='guest')
parser.add_argument('--password', help='Flow-network password', default='password')
parser.add_argument('--name', help='short channel name', default='sine')
parser.add_argument('--hz', help='samples per second', type=float, default=50.0)

sat = FlowSat()
chrono = ElapsedTime()
sine = None
args = None


def setup():
    global args
    args = parser.parse_args()
    sat.setLogin(args.user, args.password)
    sat.setTickTimer(1.0 / args.hz)
    sat.setNewChanCallBack(onChannelAdded)
    sat.setDelChanCallBack(onChannelRemoved)
    sat.setStartChanPubReqCallBack(onStartChanPub)
    sat.setStopChanPubReqCallBack(onStopChanPub)
    if not sat.connect():  # ROBOT_ADDRESS, default local:/tmp/Robot
        return False
    props = {"rate_hz": args.hz, "unit": "V", "amplitude": 1.0}
    return sat.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_FLOAT, args.name,
                                   "application/octet-stream", props=props)


def loop():
    if sine is not None and sine.isPublishingEnabled:
        sat.publishFloat(sine.chanID, math.sin(2.0 * math.pi * 0.5 * chrono.stop()))
    sat.tick()
    return sat.isConnected()


def onChannelAdded(ch):
    global sine
    if ch.name == "{}.{}".format(args.user, args.name) and ch.isOwned:  # not another's
        sine = ch
        msg("channel ready: {} (id {})".format(ch.name, ch.chanID))


def onChannelRemoved(ch):
    global sine
    if sine is not None and ch.chanID == sine.chanID:
        sine = None


def onStartChanPub(ch):
    msg("first subscriber: publishing on {}".format(ch.name))


def onStopChanPub(ch):
    msg("no subscriber left: pausing {}".format(ch.name))
