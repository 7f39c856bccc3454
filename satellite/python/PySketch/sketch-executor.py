#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The `#!PySketch/sketch-executor.py` form of the sketch executor: see executor.py."""
from __future__ import print_function, division, absolute_import

import os
import sys

_here = os.path.dirname(os.path.realpath(__file__))
sys.path = [p for p in sys.path if os.path.realpath(p or ".") != _here]
sys.path.insert(0, os.path.dirname(_here))

from PySketch.executor import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
