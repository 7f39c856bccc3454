#!/usr/bin/env pysketch-executor
# SPDX-License-Identifier: Apache-2.0
# A service caller: waits for a service channel, sends one request (non-blocking), prints the
# answer and stops.
import argparse
import json
import sys

from PySketch.elapsedtime import ElapsedTime
from PySketch.flowsat import FlowSat
from PySketch.log import msg, err

parser = argparse.ArgumentParser(description="Sends one request to a service channel")
parser.add_argument('sketchfile', help='Sketch program file')
parser.add_argument('--user', help='Flow-network username', default='guest')
parser.add_argument('--password', help='Flow-network password', default='password')
parser.add_argument('--service', help='service channel', default='guest.calc')
parser.add_argument('--cmd', help='command name', default='add')
parser.add_argument('--value', help='the request value, as JSON', default='[1, 2, 3.5]')
parser.add_argument('--timeout', help='seconds to wait', type=float, default=10.0)

sat = FlowSat()
args = None
answer = []
chrono = ElapsedTime()


def setup():
    global args
    args = parser.parse_args()
    sat.setLogin(args.user, args.password)
    sat.setTickTimer(0.01)
    sat.setNewChanCallBack(onChannelAdded)
    sat.setResponseCallBack(onServiceResponse)
    chrono.start()
    return sat.connect()


def loop():
    sat.tick()
    if chrono.stop() > args.timeout:
        err("no answer from {} in {} s".format(args.service, args.timeout))
        sys.exit(1)
    return not answer and sat.isConnected()


def onChannelAdded(ch):
    if ch.name == args.service:
        msg("sending {!r} to {}".format(args.cmd, ch.name))
        sat.sendServiceRequest(ch.chanID, args.cmd, json.loads(args.value))


def onServiceResponse(chanID, value):
    answer.append(value)
    print("answer: {}".format(json.dumps(value, sort_keys=True)))
