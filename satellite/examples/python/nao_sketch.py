#!/usr/bin/env pysketch-executor
# SPDX-License-Identifier: Apache-2.0
# The nao-bridge service, run on the Nao itself under Python 2.7 with the naoqi SDK: a service
# channel "<user>.command" (see --name) that takes the same JSON commands as the hub's
# nao-bridge module (docs/nao.md) and answers {"ok": True} or {"ok": False, "code", "error"}.
#   python2 PySketch/executor.py nao_sketch.py --user guest --password password
from __future__ import print_function, division, absolute_import

import argparse

from PySketch.flowsat import FlowSat
from PySketch.log import msg, wrn

try:
    from naoqi import ALProxy
except ImportError:  # not on a robot: every command answers not_connected
    ALProxy = None

parser = argparse.ArgumentParser(description="A Nao's motion, speech and LEDs on a service")
parser.add_argument('sketchfile', help='Sketch program file')
parser.add_argument('--user', help='Flow-network username', default='guest')
parser.add_argument('--password', help='Flow-network password', default='password')
parser.add_argument('--name', help='short service name', default='command')
parser.add_argument('--nao-ip', help='NAOqi address', default='127.0.0.1')
parser.add_argument('--nao-port', help='NAOqi port', type=int, default=9559)

# Nao V5 joint limits in radians (hands: 0 closed .. 1 open), as in plugins/nao-bridge.
LIMITS = {
    "HeadYaw": (-2.0857, 2.0857), "HeadPitch": (-0.6720, 0.5149),
    "LShoulderPitch": (-2.0857, 2.0857), "LShoulderRoll": (-0.3142, 1.3265),
    "LElbowYaw": (-2.0857, 2.0857), "LElbowRoll": (-1.5446, -0.0349),
    "LWristYaw": (-1.8238, 1.8238), "LHand": (0.0, 1.0),
    "RShoulderPitch": (-2.0857, 2.0857), "RShoulderRoll": (-1.3265, 0.3142),
    "RElbowYaw": (-2.0857, 2.0857), "RElbowRoll": (0.0349, 1.5446),
    "RWristYaw": (-1.8238, 1.8238), "RHand": (0.0, 1.0),
    "LHipYawPitch": (-1.145303, 0.740810), "LHipRoll": (-0.379472, 0.790477),
    "LHipPitch": (-1.535889, 0.484090), "LKneePitch": (-0.092346, 2.112528),
    "LAnklePitch": (-1.189516, 0.922747), "LAnkleRoll": (-0.397880, 0.769001),
    "RHipYawPitch": (-1.145303, 0.740810), "RHipRoll": (-0.790477, 0.379472),
    "RHipPitch": (-1.535889, 0.484090), "RKneePitch": (-0.103083, 2.120198),
    "RAnklePitch": (-1.186448, 0.932056), "RAnkleRoll": (-0.768992, 0.397935),
}
POSTURES = ("Stand", "StandInit", "StandZero", "Crouch", "Sit", "SitRelax", "LyingBelly",
            "LyingBack")
LED_GROUPS = ("AllLeds", "FaceLeds", "ChestLeds", "EarLeds", "FeetLeds", "LeftFaceLeds",
              "RightFaceLeds", "LeftFootLeds", "RightFootLeds")

sat = FlowSat()
service = None
args = None
proxies = {}


class Refused(Exception):
    def __init__(self, code, text):
        Exception.__init__(self, text)
        self.code = code


def number(value, key, default, low, high):
    x = value.get(key, default)
    if x is None:
        raise Refused("bad_request", "missing \"%s\"" % key)
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise Refused("bad_request", "\"%s\" must be a number" % key)
    if x < low or x > high:
        raise Refused("out_of_range", "\"%s\" = %s is outside [%s, %s]" % (key, x, low, high))
    return float(x)


def angle(name, x):
    if name not in LIMITS:
        raise Refused("out_of_range", "unknown joint \"%s\"" % name)
    low, high = LIMITS[name]
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise Refused("bad_request", "angle of %s must be a number" % name)
    if x < low or x > high:
        raise Refused("out_of_range", "%s = %s is outside its limits [%s, %s]" % (
            name, x, low, high))
    return float(x)


def rgb(x):
    if isinstance(x, list) and len(x) == 3:
        return (int(x[0]) << 16) | (int(x[1]) << 8) | int(x[2])
    if isinstance(x, basestring_type()) and len(x) == 7 and x[0] == "#":
        try:
            return int(x[1:], 16)
        except ValueError:
            pass
    raise Refused("bad_request", "\"rgb\" must be \"#rrggbb\" or [r, g, b]")


def basestring_type():
    try:
        return basestring
    except NameError:  # Python 3, for tests off the robot
        return str


def proxy(name):
    if ALProxy is None:
        raise Refused("not_connected", "the naoqi SDK is not available here")
    if name not in proxies:
        try:
            proxies[name] = ALProxy(name, args.nao_ip, args.nao_port)
        except Exception as e:
            raise Refused("not_connected", "%s: %s" % (name, e))
    return proxies[name]


def run(cmd, value):
    if not isinstance(value, dict):
        value = {}
    cmd = value.get("cmd", cmd)
    if cmd == "say":
        text = value.get("text")
        if not isinstance(text, basestring_type()) or not 0 < len(text) <= 2000:
            raise Refused("out_of_range", "\"text\" must have 1 to 2000 bytes")
        proxy("ALTextToSpeech").say(str(text))
    elif cmd == "posture":
        name = value.get("name")
        if name not in POSTURES:
            raise Refused("out_of_range", "unknown posture \"%s\"" % name)
        if not proxy("ALRobotPosture").goToPosture(name, number(value, "speed", 0.5, 0.01, 1)):
            raise Refused("robot_error", "posture %s not reached" % name)
    elif cmd in ("head", "joints"):
        if cmd == "head":
            names = [n for n in ("HeadYaw", "HeadPitch") if n[4:].lower() in value]
            angles = [value[n[4:].lower()] for n in names]
        else:
            names, angles = value.get("names"), value.get("angles")
        if not isinstance(names, list) or not isinstance(angles, list) or \
                len(names) != len(angles) or not names:
            raise Refused("bad_request", "\"names\" and \"angles\" must be arrays of one length")
        angles = [angle(n, a) for n, a in zip(names, angles)]
        proxy("ALMotion").setAngles([str(n) for n in names], angles,
                                    number(value, "speed", 0.2, 0.01, 1))
    elif cmd == "walk":
        proxy("ALMotion").moveToward(number(value, "x", 0, -1, 1), number(value, "y", 0, -1, 1),
                                     number(value, "theta", 0, -1, 1))
    elif cmd == "stop":
        proxy("ALMotion").stopMove()
    elif cmd == "rest":
        proxy("ALMotion").rest()
    elif cmd == "wake":
        proxy("ALMotion").wakeUp()
    elif cmd == "leds":
        group = value.get("group")
        if group not in LED_GROUPS:
            raise Refused("out_of_range", "unknown LED group \"%s\"" % group)
        proxy("ALLeds").fadeRGB(str(group), rgb(value.get("rgb")),
                                number(value, "duration", 0, 0, 60))
    else:
        raise Refused("unknown_command", "unknown command \"%s\"" % cmd)


def setup():
    global args
    args = parser.parse_args()
    sat.setLogin(args.user, args.password)
    sat.setTickTimer(0.02)
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
        msg("nao service ready: {} (NAOqi at {}:{})".format(ch.name, args.nao_ip, args.nao_port))


def onServiceRequest(chanID, hash, cmdName, value):
    if service is None or chanID != service.chanID:
        return
    try:
        run(cmdName, value)
        answer = {"ok": True}
    except Refused as e:
        answer = {"ok": False, "code": e.code, "error": str(e)}
    except Exception as e:  # a NAOqi call failed (RuntimeError from the SDK)
        proxies.clear()     # reconnect the proxies at the next command
        wrn("NAOqi: {}".format(e))
        answer = {"ok": False, "code": "robot_error", "error": str(e)}
    sat.sendServiceResponse(chanID, hash, answer)
