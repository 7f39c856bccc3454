# SPDX-License-Identifier: Apache-2.0
"""Console logging for sketches: msg (info), dbg (debug), wrn (warning), err (error),
cri (critical), printPair(key, value). Each takes any objects, like print().

msg and dbg write to stdout, wrn/err/cri to stderr, one line each, flushed at once:
    12:30:01.250 [MSG] text
setLevel("dbg"|"msg"|"wrn"|"err"|"cri") hides lower levels; PYSKETCH_LOG_LEVEL sets it too.
"""
from __future__ import print_function, division, absolute_import

import os
import sys
import time

_LEVELS = ["dbg", "msg", "wrn", "err", "cri"]
_level = os.environ.get("PYSKETCH_LOG_LEVEL", "dbg").lower()
if _level not in _LEVELS:
    _level = "dbg"


def setLevel(level):
    """Lowest level shown: "dbg", "msg", "wrn", "err" or "cri"."""
    global _level
    level = str(level).lower()
    if level not in _LEVELS:
        raise ValueError("log level must be one of %s" % ", ".join(_LEVELS))
    _level = level


def _stamp():
    t = time.time()
    return time.strftime("%H:%M:%S", time.localtime(t)) + ".%03d" % int((t % 1) * 1000)


def _write(level, args, stream):
    if _LEVELS.index(level) < _LEVELS.index(_level):
        return
    text = " ".join(str(a) for a in args)
    out = stream if stream is not None else (sys.stdout if level in ("dbg", "msg") else sys.stderr)
    try:
        out.write("%s [%s] %s\n" % (_stamp(), level.upper(), text))
        out.flush()
    except (IOError, OSError, ValueError):
        pass


def msg(*args):
    _write("msg", args, None)


def dbg(*args):
    _write("dbg", args, None)


def wrn(*args):
    _write("wrn", args, None)


def err(*args):
    _write("err", args, None)


def cri(*args):
    _write("cri", args, None)


def printPair(key, value, *more):
    """Prints `key: value` (and any further values) as a MSG line."""
    _write("msg", ["%s: %s" % (key, " ".join(str(v) for v in (value,) + more))], None)
