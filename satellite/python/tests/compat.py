# SPDX-License-Identifier: Apache-2.0
"""What the tests need that Python 2.7 spells differently (the suite runs under Debian's python3
and under Python 2.7.18, see test_python27.py)."""
import contextlib
import io
import sys
import unittest

PY2 = sys.version_info[0] == 2
from PySketch.elapsedtime import now as monotonic  # noqa: E402 (PySketch's clock, also on 2.7)

if not hasattr(unittest.TestCase, "assertRegex"):  # Python 2.7
    unittest.TestCase.assertRegex = unittest.TestCase.assertRegexpMatches
    unittest.TestCase.assertNotRegex = unittest.TestCase.assertNotRegexpMatches


def TextIO():
    """A text buffer that print() and PySketch.log can write to (str on both)."""
    return io.BytesIO() if PY2 else io.StringIO()


@contextlib.contextmanager
def _redirect(name, stream):
    old = getattr(sys, name)
    setattr(sys, name, stream)
    try:
        yield stream
    finally:
        setattr(sys, name, old)


def redirect_stdout(stream):
    return _redirect("stdout", stream)


def redirect_stderr(stream):
    return _redirect("stderr", stream)
