# SPDX-License-Identifier: Apache-2.0
"""ElapsedTime: a stopwatch. start() (re)starts it, stop() returns the seconds since the last
start() as a float, without stopping anything (it can be read again and again). A new
ElapsedTime starts at once."""
from __future__ import print_function, division, absolute_import

import time



def _libcMonotonic():
    """clock_gettime(CLOCK_MONOTONIC) through ctypes, for Python 2.7 (None if unavailable)."""
    try:
        import ctypes
        import ctypes.util

        class _Timespec(ctypes.Structure):
            _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]

        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        gettime = libc.clock_gettime
        gettime.argtypes = [ctypes.c_int, ctypes.POINTER(_Timespec)]
        ts = _Timespec()

        def monotonic():
            if gettime(1, ctypes.byref(ts)) != 0:  # 1: CLOCK_MONOTONIC on Linux
                raise OSError(ctypes.get_errno(), "clock_gettime(CLOCK_MONOTONIC) failed")
            return ts.tv_sec + ts.tv_nsec * 1e-9

        monotonic()
        return monotonic
    except (ImportError, OSError, AttributeError):  # pragma: no cover
        return None


try:
    _now = time.monotonic  # Python 3
except AttributeError:  # Python 2.7: no monotonic clock in time; wall time only as a last resort
    _now = _libcMonotonic() or time.time


def now():
    """The clock every PySketch timer uses (monotonic where the interpreter has one)."""
    return _now()


class ElapsedTime(object):
    def __init__(self):
        self._start = _now()

    def start(self):
        """Restarts the stopwatch."""
        self._start = _now()

    def stop(self):
        """Seconds since the last start(), as a float."""
        return _now() - self._start

    elapsed = stop

    def __repr__(self):
        return "ElapsedTime(%.6f s)" % self.stop()
