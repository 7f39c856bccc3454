"""ElapsedTime: a stopwatch. start() (re)starts it, stop() returns the seconds since the last
start() as a float, without stopping anything (it can be read again and again). A new
ElapsedTime starts at once."""
from __future__ import print_function, division, absolute_import

import time

try:
    _now = time.monotonic  # Python 3
except AttributeError:  # pragma: no cover - Python 2.7 has no monotonic clock in time
    _now = time.time


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
