# SPDX-License-Identifier: Apache-2.0
"""The example sketches (satellite/examples/python) run the way users run them, and the
executor's contract: shebang forms, argv, setup/loop/close, exit status."""
import os
import re
import shutil
import signal
import sys
import tempfile
import textwrap
import unittest

from tests.hubtest import EXAMPLES, EXECUTOR, PYROOT, PYTHON, SCRIPTS, HubTestCase, Sketch

CREDENTIALS = ["--user", "guest", "--password", "password"]


def example(name):
    return os.path.join(EXAMPLES, name)


class Examples(HubTestCase):
    echo_module = True

    def run_sketch(self, argv, cwd=None, **env):
        s = Sketch(argv, self.hub.env(**env), cwd)
        self.addCleanup(lambda: s.alive() and s.stop(signal.SIGKILL))
        return s

    def test_examples_start_with_an_executor_line_and_are_short(self):
        for name in ("publisher.py", "subscriber.py", "service_provider.py", "service_caller.py"):
            with open(example(name)) as f:
                lines = f.read().splitlines()
            self.assertEqual(lines[0], "#!/usr/bin/env pysketch-executor", name)
            self.assertLess(len(lines), 80, name)
            self.assertTrue(os.access(example(name), os.X_OK), name + " is executable")

    def test_publisher_and_subscriber(self):
        # Run directly: the kernel finds pysketch-executor on PATH through the first line.
        pub = self.run_sketch([example("publisher.py")] + CREDENTIALS + ["--hz", "100"])
        pub.waitFor(r"channel ready: guest\.sine \(id \d+\)")
        self.assertFalse(pub.matching("first subscriber"), "nobody listens yet")
        sub = self.run_sketch([EXECUTOR, example("subscriber.py")] + CREDENTIALS +
                              ["--channel", "guest.sine", "--count", "20"])
        self.assertEqual(sub.wait(), 0, sub.output())
        values = [float(v) for v in re.findall(r"^guest\.sine: (-?\d+\.\d+)$", sub.output(), re.M)]
        self.assertGreaterEqual(len(values), 20, sub.output())
        self.assertTrue(all(-1.0 <= v <= 1.0 for v in values), values)
        self.assertGreater(len(set(values)), 1, "a sine, not a constant")
        self.assertIn("found guest.sine", sub.output())
        self.assertIn("received %d values" % len(values), sub.output(), "close() ran")
        pub.waitFor(r"first subscriber: publishing on guest\.sine")
        pub.waitFor(r"no subscriber left: pausing guest\.sine")
        self.assertEqual(pub.stop(signal.SIGTERM), 0, pub.output())
        self.assertIn("stopped by SIGTERM", pub.output())

    def test_service_provider_and_caller(self):
        provider = self.run_sketch([example("service_provider.py")] + CREDENTIALS)
        provider.waitFor(r"service ready: guest\.calc")
        for cmd, value, answer in (("add", "[1, 2, 3.5]", "6.5"), ("upper", '"abc"', '"ABC"'),
                                   ("nope", "null", '{"error": "unknown command nope"}')):
            caller = self.run_sketch([example("service_caller.py")] + CREDENTIALS +
                                     ["--service", "guest.calc", "--cmd", cmd, "--value", value])
            self.assertEqual(caller.wait(), 0, caller.output())
            self.assertIn("answer: " + answer, caller.output())
        provider.waitFor(r"request \d+ 'add': \[1, 2, 3\.5\]")
        self.assertEqual(provider.stop(signal.SIGINT), 0, provider.output())

    def test_nao_sketch_off_the_robot(self):
        # Without the naoqi SDK every valid command answers not_connected; bad ones are refused
        # before that. The sketch is meant for Python 2.7 on the Nao: python27_* runs it there.
        nao = self.run_sketch([example("nao_sketch.py")] + CREDENTIALS)
        nao.waitFor(r"nao service ready: guest\.command")
        for value, code in (('{"cmd": "say", "text": "hello"}', "not_connected"),
                            ('{"cmd": "head", "yaw": 9}', "out_of_range"),
                            ('{"cmd": "dance"}', "unknown_command")):
            caller = self.run_sketch([example("service_caller.py")] + CREDENTIALS +
                                     ["--service", "guest.command", "--cmd", "x",
                                      "--value", value])
            self.assertEqual(caller.wait(), 0, caller.output())
            self.assertRegex(caller.output(), r'answer: \{.*"code": "%s"' % code)
            self.assertIn('"ok": false', caller.output())
        self.assertEqual(nao.stop(signal.SIGTERM), 0, nao.output())

    def test_caller_and_the_in_hub_module(self):
        caller = self.run_sketch([example("service_caller.py")] + CREDENTIALS +
                                 ["--service", "test_channel_echo.svc", "--cmd", "ping",
                                  "--value", '{"x": [1, true]}'])
        self.assertEqual(caller.wait(), 0, caller.output())
        self.assertIn('answer: {"cmd": "ping", "echo": {"x": [1, true]}}', caller.output())

    def test_caller_gives_up_without_a_service(self):
        caller = self.run_sketch([example("service_caller.py")] + CREDENTIALS +
                                 ["--service", "guest.none", "--timeout", "0.3"])
        self.assertEqual(caller.wait(), 1, caller.output())
        self.assertIn("no answer from guest.none", caller.output())

    def test_compat_shebang_forms(self):
        """#!PySketch/executor.py and #!PySketch/sketch-executor.py, relative to the sketch's
        directory with a copy of PySketch next to it (the Python 2.7 route), an absolute path
        like #!/usr/local/bin/pysketch-executor, and python3 -m PySketch.executor."""
        work = tempfile.mkdtemp(prefix="pysketch-")
        self.addCleanup(shutil.rmtree, work, True)
        shutil.copytree(os.path.join(PYROOT, "PySketch"), os.path.join(work, "PySketch"))
        with open(example("service_caller.py")) as f:
            body = f.read().split("\n", 1)[1]
        forms = {"exe.py": "#!PySketch/executor.py", "sk.py": "#!PySketch/sketch-executor.py",
                 "abs.py": "#!" + EXECUTOR}
        for name, line in forms.items():
            path = os.path.join(work, name)
            with open(path, "w") as f:
                f.write(line + "\n" + body)
            os.chmod(path, 0o755)
        args = CREDENTIALS + ["--service", "test_channel_echo.svc", "--value", '"%s"']
        # No PYTHONPATH: the PySketch next to the sketch is the one imported.
        runs = [(["./" + name] + args[:-1] + [args[-1] % name], {}) for name in forms]
        runs.append(([PYTHON, "-m", "PySketch.executor", "abs.py"] + args[:-1] +
                     [args[-1] % "module"], {"PYTHONPATH": work}))
        for argv, env in runs:
            env.setdefault("PYTHONPATH", "")
            s = self.run_sketch(argv, cwd=work, **env)
            self.assertEqual(s.wait(), 0, " ".join(argv) + "\n" + s.output())
            self.assertRegex(s.output(), r'answer: \{"cmd": "add", "echo": "[a-z]+(\.py)?"\}')

    def test_executor_contract(self):
        work = tempfile.mkdtemp(prefix="pysketch-")
        self.addCleanup(shutil.rmtree, work, True)
        with open(os.path.join(work, "helper_next_to_sketch.py"), "w") as f:
            f.write("VALUE = 42\n")
        sketch = os.path.join(work, "contract.py")
        with open(sketch, "w") as f:
            f.write(textwrap.dedent("""\
                from __future__ import print_function, division
                import argparse, os, sys, time
                import helper_next_to_sketch
                from PySketch.flowsat import FlowSat
                parser = argparse.ArgumentParser()
                parser.add_argument('sketchfile')
                parser.add_argument('--loops', type=int, default=3)
                parser.add_argument('--fail-setup', action='store_true')
                parser.add_argument('--forever', action='store_true')
                parser.add_argument('--user', default='guest')
                parser.add_argument('--password', default='password')
                count = 0
                print("name", __name__, "helper", helper_next_to_sketch.VALUE)
                def setup():
                    global args
                    args = parser.parse_args()
                    print("sketchfile", os.path.basename(args.sketchfile))
                    print("division", 1 / 2)
                    return not args.fail_setup
                def loop():
                    global count
                    count += 1
                    if args.forever:
                        if count == 1:
                            print("looping")
                        time.sleep(0.01)
                        return True
                    return count < args.loops
                def close():
                    print("close after", count, "loops")
                """))
        s = self.run_sketch([EXECUTOR, sketch, "--loops", "5", "--user", "guest"])
        self.assertEqual(s.wait(), 0, s.output())
        out = s.output()
        self.assertIn("name __sketch__ helper 42", out)
        self.assertIn("sketchfile contract.py", out)
        self.assertIn("division 0.5", out)
        self.assertIn("close after 5 loops", out)

        s = self.run_sketch([EXECUTOR, sketch, "--fail-setup"])
        self.assertEqual(s.wait(), 1, s.output())
        self.assertIn("setup() returned False", s.output())
        self.assertNotIn("close after", s.output())

        for sig, name in ((signal.SIGINT, "SIGINT"), (signal.SIGTERM, "SIGTERM")):
            s = self.run_sketch([EXECUTOR, sketch, "--forever"])
            s.waitFor("looping")
            self.assertEqual(s.stop(sig), 0, s.output())
            self.assertIn("stopped by " + name, s.output())
            self.assertRegex(s.output(), r"close after \d+ loops")

        s = self.run_sketch([EXECUTOR])
        self.assertEqual(s.wait(), 2)
        self.assertIn("usage: pysketch-executor", s.output())
        s = self.run_sketch([EXECUTOR, os.path.join(work, "missing.py")])
        self.assertEqual(s.wait(), 2)
        broken = os.path.join(work, "broken.py")
        with open(broken, "w") as f:
            f.write("def setup():\n    return True\ndef loop():\n    raise RuntimeError('bug')\n")
        s = self.run_sketch([EXECUTOR, broken])
        self.assertEqual(s.wait(), 1)
        self.assertIn("RuntimeError: bug", s.output())


if __name__ == "__main__":
    unittest.main()
