# SPDX-License-Identifier: Apache-2.0
"""A sketch as a satellite the hub supervises (docs/robot.md), under the interpreter that runs
this suite (Python 2.7 in python27_test_supervised): it logs in with the account and password the
hub puts in its environment ($ROBOT_USER, $ROBOT_PASSWORD), and the hub stops it at its own stop."""
import os
import sys
import tempfile
import textwrap
import unittest

from tests.hubtest import EXECUTOR, PYROOT, Hub, waitUntil

SKETCH = textwrap.dedent("""\
    import sys
    from PySketch.flowproto import Flow_T, Variant_T
    from PySketch.flowsat import FlowSat

    sat = FlowSat()

    def setup():
        sat.setTickTimer(0.02)
        if not sat.connect():
            return False
        print("python %d.%d as %s" % (sys.version_info[0], sys.version_info[1], sat._userName))
        sys.stdout.flush()
        return sat.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_FLOAT, "supervised")

    def loop():
        sat.tick()
        return sat.isConnected()
    """)


class Supervised(unittest.TestCase):
    def test_a_sketch_logs_in_with_the_password_the_hub_made_for_it(self):
        fd, sketch = tempfile.mkstemp(suffix=".py", prefix="supervised-")
        with os.fdopen(fd, "w") as f:
            f.write(SKETCH)
        self.addCleanup(os.remove, sketch)
        hub = Hub("supervised", satellites=[{
            "name": "sketch", "command": [EXECUTOR, sketch], "account": "guest",
            "ready": "login", "env": {"PYTHONPATH": PYROOT, "PYTHONDONTWRITEBYTECODE": "1"}}])
        self.addCleanup(hub.close)
        hub.start()
        # Up once it logged in with its run's password (the development account's would not do).
        self.assertTrue(waitUntil(lambda: "SAT-READY sketch is up (logged in)" in hub.log()),
                        hub.log())
        self.assertIn("(supervised satellite sketch)", hub.log())
        version = "python %d.%d as guest" % sys.version_info[:2]
        self.assertTrue(waitUntil(lambda: version in hub.log()), hub.log())
        self.assertTrue(waitUntil(lambda: "FLOW-CHANNEL-ADDED guest.supervised" in hub.log()),
                        hub.log())
        hub.stop()
        self.assertIn("SAT-STOPPING sketch", hub.log())
        self.assertIn("SAT-EXITED sketch", hub.log())
        self.assertIn("HUB-STOP", hub.log())
        self.assertLess(hub.log().index("SAT-EXITED sketch"), hub.log().index("HUB-STOP"))


if __name__ == "__main__":
    unittest.main()
