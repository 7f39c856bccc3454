# SPDX-License-Identifier: Apache-2.0
"""Physical mode with a PySketch channel OWNER (PySketch/flowowner.py, docs/physical-mode.md).

test_paths.py's hub tests (PathsWithAHub) again, with tests/paths_publisher.py (the PySketch twin
of the C++ paths_publisher) as the owner: shared memory in place, a direct path in order, a
switch that loses nothing, fallback without loss or duplicates, a slow reader, the hub's counts,
an owner killed, a hub restarted.
"""
import unittest

from tests import test_paths


class PathsFromAPythonOwner(test_paths.PathsWithAHub):
    OWNER = test_paths.PYTHON_OWNER


if __name__ == "__main__":
    unittest.main()
