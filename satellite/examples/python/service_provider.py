#!/usr/bin/env pysketch-executor
# SPDX-License-Identifier: Apache-2.0
# A service provider: "<user>.calc" answers "add" (the sum of a list of numbers), "upper" (a
# string in capitals) and "echo" (the value itself); anything else gets an error map.
import argparse

from PySketch.flowsat import FlowSat
from PySketch.log import msg

parser = argparse.ArgumentParser(description="Answers requests on a service channel")
parser.add_argument('sketchfile', help='Sketch program file')
parser.add_argument('--user', help='Flow-network username', default='guest')
parser.add_argument('--password', help='Flow-network password', default='password')
parser.add_argument('--name', help='short service name', default='calc')

sat = FlowSat()
service = None
args = None


def setup():
    global args
    args = parser.parse_args()
    sat.setLogin(args.user, args.password)
    sat.setTickTimer(0.01)
    sat.setNewChanCallBack(onChannelAdded)
    sat.setRequestCallBack(onServiceRequest)
    if not sat.connect():
        return False
    return sat.addServiceChannel(args.name)


def loop():
    sat.tick()
    return sat.isConnected()


def onChannelAdded(ch):
    global service
    if ch.name == "{}.{}".format(args.user, args.name):
        service = ch
        msg("service ready: {} (id {})".format(ch.name, ch.chanID))


def onServiceRequest(chanID, hash, cmdName, value):
    if service is None or chanID != service.chanID:
        return
    msg("request {} {!r}: {!r}".format(hash, cmdName, value))
    if cmdName == "add":
        answer = sum(value)
    elif cmdName == "upper":
        answer = value.upper()
    elif cmdName == "echo":
        answer = value
    else:
        answer = {"error": "unknown command " + cmdName}
    sat.sendServiceResponse(chanID, hash, answer)
