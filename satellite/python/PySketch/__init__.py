# SPDX-License-Identifier: Apache-2.0
"""PySketch: Python satellites for the skrobot hub, compatible with the PySketch API.

Modules: flowsat (FlowSat), robotmod (RobotModule), abstractflow (FlowChannel), flowproto
(FlowChanID, Variant_T, Flow_T, the Variant codec), flowsync (FlowSync), elapsedtime
(ElapsedTime), databuffer (DataBuffer), log (msg, dbg, wrn, err, cri, printPair) and executor
(runs a sketch: setup() once, loop() until it returns False, close() at exit).

Pure standard library; parses under Python 2.7 and runs under Python 3. See
docs/python-satellites.md.
"""
from __future__ import print_function, division, absolute_import

__version__ = "1.0.0"
