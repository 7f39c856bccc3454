# SPDX-License-Identifier: Apache-2.0
"""RobotModule: the older name of FlowSat, with the same methods."""
from __future__ import print_function, division, absolute_import

from PySketch.flowsat import FlowSat


class RobotModule(FlowSat):
    pass
