# SPDX-License-Identifier: Apache-2.0
"""Test helpers: a private hub (the real skrobot binary with a temporary config), sketches run
as subprocesses, and a loop that ticks in-process satellites until something happens.

Environment (set by CTest, see ../CMakeLists.txt):
    SKROBOT_BIN              the hub binary
    SKROBOT_TEST_MODULE_DIR  where test_channel_echo.so is

Sketches run under the interpreter that runs the tests (sys.executable): Debian's python3, or
Python 2.7 (test_python27.py runs this whole suite under it).
"""
import atexit
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

from tests.compat import PY2, monotonic

HERE = os.path.dirname(os.path.abspath(__file__))
PYROOT = os.path.dirname(HERE)                                  # satellite/python
REPO = os.path.dirname(os.path.dirname(PYROOT))
EXAMPLES = os.path.join(REPO, "satellite", "examples", "python")
PYTHON = sys.executable
if PYTHON == "/usr/bin/python3":
    SCRIPTS = os.path.join(PYROOT, "scripts")
else:
    # The source tree's pysketch-executor names python3 in its first line: put a twin that
    # runs it under this interpreter first on the sketches' PATH.
    SCRIPTS = tempfile.mkdtemp(prefix="pysketch-bin-")
    atexit.register(shutil.rmtree, SCRIPTS, True)
    with open(os.path.join(SCRIPTS, "pysketch-executor"), "w") as _f:
        _f.write('#!/bin/sh\nexec "%s" "%s" "$@"\n'
                 % (PYTHON, os.path.join(PYROOT, "scripts", "pysketch-executor")))
    os.chmod(os.path.join(SCRIPTS, "pysketch-executor"), 0o755)
EXECUTOR = os.path.join(SCRIPTS, "pysketch-executor")
TIMEOUT = 10.0       # the longest anything is expected to take, on a loaded machine
HUB_START_TIMEOUT = 30.0

_counter = itertools.count()


def skrobotBin():
    path = os.environ.get("SKROBOT_BIN")
    if not path:
        raise unittest.SkipTest("SKROBOT_BIN is not set (run through ctest)")
    return path


def moduleDir():
    path = os.environ.get("SKROBOT_TEST_MODULE_DIR")
    if not path:
        raise unittest.SkipTest("SKROBOT_TEST_MODULE_DIR is not set (run through ctest)")
    return path


def waitUntil(cond, timeout=TIMEOUT, step=0.01):
    deadline = monotonic() + timeout
    while monotonic() < deadline:
        if cond():
            return True
        time.sleep(step)
    return cond()


class Hub(object):
    """A hub on /tmp/<unique app name>, with guest/password and optionally the echo module."""

    def __init__(self, name, echo_module=False, hub_name=None, links=(), modules=(), server=None,
                 project_modules=(), satellites=()):
        """hub_name and links (other Hub objects, linked with guest/password): hub links;
        modules: names of more test modules (<name>.so in SKROBOT_TEST_MODULE_DIR) to load;
        project_modules: entries of the config's "modules" list, as given ({"name": "face-detect",
        "config": {...}}: the project's modules, found beside the hub binary);
        server: keys of the config's "server" object; satellites: entries of its "satellites"
        list (processes the hub supervises, docs/robot.md)."""
        self.dir = tempfile.mkdtemp(prefix="pysat-")
        self.app = "pysat-%s-%d-%d" % (name, os.getpid(), next(_counter))
        self.address = "local:/tmp/" + self.app
        cfg = {
            "app_name": self.app,
            "data_dir": os.path.join(self.dir, "data"),
            "log": {"level": "info"},
            "accounts": {"dev_account": {"user": "guest", "password": "password"}},
        }
        if server:
            cfg["server"] = dict(server)
        if echo_module:
            cfg["modules"] = [{"path": os.path.join(moduleDir(), "test_channel_echo.so")}]
        for m in modules:
            cfg.setdefault("modules", []).append({"path": os.path.join(moduleDir(), m + ".so")})
        for m in project_modules:
            cfg.setdefault("modules", []).append(dict(m))
        if satellites:
            cfg["satellites"] = [dict(s) for s in satellites]
        if hub_name:
            cfg["hub_name"] = hub_name
            self.hub_name = hub_name
        if links:
            cfg["links"] = []
            for other in links:
                password_file = os.path.join(self.dir, other.hub_name + ".pass")
                with open(password_file, "w") as f:
                    f.write("password\n")
                os.chmod(password_file, 0o600)
                cfg["links"].append({"name": other.hub_name, "address": other.address,
                                     "user": "guest", "password_file": password_file})
        self.config = os.path.join(self.dir, "hub.json")
        with open(self.config, "w") as f:
            json.dump(cfg, f)
        self.proc = None
        self.runs = 0

    def logPath(self, run=None):
        return os.path.join(self.dir, "hub-%d.log" % (self.runs if run is None else run))

    def log(self, run=None):
        try:
            with open(self.logPath(run)) as f:
                return f.read()
        except IOError:
            return ""

    def start(self):
        self.runs += 1
        out = open(self.logPath(), "w")
        self.proc = subprocess.Popen([skrobotBin(), "--config", self.config], stdout=out,
                                     stderr=subprocess.STDOUT)
        out.close()
        ok = waitUntil(lambda: "HUB-READY" in self.log() or self.proc.poll() is not None,
                       HUB_START_TIMEOUT)
        if not ok or "HUB-READY" not in self.log():
            raise AssertionError("the hub did not start:\n" + self.log())
        return self

    def stop(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            if not waitUntil(lambda: self.proc.poll() is not None, TIMEOUT):
                self.proc.kill()
                self.proc.wait()
        self.proc = None

    def close(self):
        self.stop()
        shutil.rmtree(self.dir, ignore_errors=True)

    def env(self, **extra):
        """Environment for a sketch: this hub's address, this tree's PySketch, Debian's python3
        and the source tree's pysketch-executor first on PATH."""
        env = dict(os.environ)
        env["ROBOT_ADDRESS"] = self.address
        env["PYTHONPATH"] = PYROOT
        env["PYTHONDONTWRITEBYTECODE"] = "1"
        env["PATH"] = SCRIPTS + ":/usr/bin:/bin"
        env.update(extra)
        return env


class Sketch(object):
    """A subprocess whose output lines are collected (with their arrival time) by a thread."""

    def __init__(self, argv, env, cwd=None, stdin=False):
        self.argv = argv
        self.lines = []          # (monotonic time, text)
        self.lock = threading.Lock()
        text = {} if PY2 else {"encoding": "utf-8", "errors": "replace"}
        self.proc = subprocess.Popen(argv, env=env, cwd=cwd, stdout=subprocess.PIPE,
                                     stdin=subprocess.PIPE if stdin else None,
                                     stderr=subprocess.STDOUT, **text)
        self.reader = threading.Thread(target=self._read)
        self.reader.daemon = True
        self.reader.start()

    def _read(self):
        # readline(): Python 2's file iterator reads ahead 8 KiB before yielding a line.
        for line in iter(self.proc.stdout.readline, ""):
            with self.lock:
                self.lines.append((monotonic(), line.rstrip("\n")))

    def output(self):
        with self.lock:
            return "\n".join(text for _, text in self.lines)

    def last(self):
        """The last line so far ("" before the first)."""
        with self.lock:
            return self.lines[-1][1] if self.lines else ""

    def send(self, line):
        """A line to the process's stdin (made with stdin=True)."""
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def matching(self, pattern, since=0.0):
        rx = re.compile(pattern)
        with self.lock:
            return [text for t, text in self.lines if t >= since and rx.search(text)]

    def waitFor(self, pattern, count=1, since=0.0, timeout=TIMEOUT):
        ok = waitUntil(lambda: len(self.matching(pattern, since)) >= count, timeout)
        if not ok:
            raise AssertionError("%s: no %d line(s) matching %r in %.0f s; output:\n%s"
                                 % (" ".join(self.argv), count, pattern, timeout, self.output()))
        return self.matching(pattern, since)

    def wait(self, timeout=TIMEOUT):
        if not waitUntil(lambda: self.proc.poll() is not None, timeout):
            self.proc.kill()
            self.proc.wait()
            raise AssertionError("%s did not end in %.0f s; output:\n%s"
                                 % (" ".join(self.argv), timeout, self.output()))
        self.reader.join(TIMEOUT)
        self.proc.stdout.close()
        return self.proc.returncode

    def stop(self, sig=signal.SIGTERM):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        return self.wait()

    def alive(self):
        return self.proc.poll() is None


def pump(sats, cond, timeout=TIMEOUT):
    """Ticks every satellite in turn until cond() is true; returns cond()."""
    deadline = monotonic() + timeout
    while monotonic() < deadline:
        for s in sats:
            s.tick()
        if cond():
            return True
    return cond()


def tickFor(sats, seconds):
    deadline = monotonic() + seconds
    while monotonic() < deadline:
        for s in sats:
            s.tick()


class HubTestCase(unittest.TestCase):
    """Starts a hub before each test and stops it after; satellites made with sat() are closed."""
    echo_module = False
    modules = ()  # more test modules to load (Hub's modules)
    server = None  # keys of the hub config's "server" object
    project_modules = ()  # entries of the config's "modules" list (Hub's project_modules)

    def setUp(self):
        self.hub = Hub(self.id().split(".")[-1][5:20].replace("_", "-") or "t",
                       self.echo_module, modules=self.modules, server=self.server,
                       project_modules=self.project_modules)
        self.addCleanup(self.hub.close)
        self.hub.start()
        self._sats = []
        self.addCleanup(self._closeSats)

    def _closeSats(self):
        for s in self._sats:
            s.close()

    def sat(self, cls=None, tick=0.005, user="guest", password="password"):
        from PySketch.flowsat import FlowSat
        s = (cls or FlowSat)()
        s.setLogin(user, password)
        s.setAddress(self.hub.address)
        s.setTickTimer(tick)
        self._sats.append(s)
        return s

    def connected(self, **kw):
        s = self.sat(**kw)
        self.assertTrue(s.connect(), "connect() to " + self.hub.address)
        return s
