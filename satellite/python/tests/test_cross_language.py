# SPDX-License-Identifier: Apache-2.0
"""Python sketches and C++ satellites on one hub: streaming data and services, both ways. The
C++ programs are the examples of satellite/examples/cpp, built by CMake
(SKROBOT_SAT_EXAMPLES_DIR)."""
from __future__ import print_function

import os
import re
import signal
import unittest

from tests.hubtest import EXAMPLES, HubTestCase, Sketch, pump

CREDENTIALS = ["--user", "guest", "--password", "password"]


class CrossLanguage(HubTestCase):
    def setUp(self):
        self.cpp_dir = os.environ.get("SKROBOT_SAT_EXAMPLES_DIR", "")
        if not os.path.isfile(os.path.join(self.cpp_dir, "publisher")):
            self.fail("SKROBOT_SAT_EXAMPLES_DIR must hold the built C++ examples (run via CTest)")
        HubTestCase.setUp(self)

    def run_program(self, argv):
        p = Sketch(argv, self.hub.env())
        self.addCleanup(lambda: p.alive() and p.stop(signal.SIGKILL))
        return p

    def cpp(self, name):
        return os.path.join(self.cpp_dir, name)

    def test_cpp_publisher_to_python_subscriber_with_properties(self):
        pub = self.run_program([self.cpp("publisher"), "100"])
        pub.waitFor(r"channel guest\.counter ready")
        sat = self.connected()
        got = []

        def onNew(ch):
            if ch.name == "guest.counter":
                sat.subscribeChannel(ch.chanID)

        sat.setNewChanCallBack(onNew)
        sat.setGrabDataCallBack(lambda chanID, data: got.append(bytes(data).decode()))
        self.assertTrue(pump([sat], lambda: len(got) >= 10), "no data from the C++ publisher")
        values = [int(v) for v in got]
        self.assertEqual(values, list(range(values[0], values[0] + len(values))), values)
        pub.waitFor(r"first subscriber: publishing")
        # The C++ satellite's channel properties, read by Python through FlowSync.
        sync = sat.newSyncClient()
        try:
            sync.setCurrentDbName("guest.counter")
            self.assertEqual(sync.getVariable("unit"), "ticks")
        finally:
            sync.close()

    def test_python_publisher_to_cpp_subscriber(self):
        pub = self.run_program([os.path.join(EXAMPLES, "publisher.py")] + CREDENTIALS +
                               ["--hz", "100"])
        pub.waitFor(r"channel ready: guest\.sine")
        sub = self.run_program([self.cpp("subscriber"), "guest.sine", "10"])
        self.assertEqual(sub.wait(), 0, sub.output())
        self.assertIn("subscribed to guest.sine", sub.output())
        pub.waitFor(r"first subscriber: publishing on guest\.sine")
        self.assertEqual(pub.stop(signal.SIGTERM), 0, pub.output())

    def test_cpp_caller_to_python_service(self):
        provider = self.run_program([os.path.join(EXAMPLES, "service_provider.py")] + CREDENTIALS)
        provider.waitFor(r"service ready: guest\.calc")
        caller = self.run_program([self.cpp("service_caller"), "guest.calc"])
        self.assertEqual(caller.wait(), 0, caller.output())
        self.assertRegex(caller.output(), r"blocking: 1 \+ 2 \+ 3 = 6(\.0)?\b")
        self.assertRegex(caller.output(), r"async: 4 \+ 5 = 9(\.0)?\b")

    def test_python_caller_to_cpp_service(self):
        provider = self.run_program([self.cpp("service_provider")])
        provider.waitFor(r"serving guest\.adder")
        caller = self.run_program([os.path.join(EXAMPLES, "service_caller.py")] + CREDENTIALS +
                                  ["--service", "guest.adder", "--cmd", "add",
                                   "--value", "[1, 2, 3.5]"])
        self.assertEqual(caller.wait(), 0, caller.output())
        self.assertTrue(re.search(r"answer: 6\.5", caller.output()), caller.output())


if __name__ == "__main__":
    unittest.main()
