# SPDX-License-Identifier: Apache-2.0
"""The hub process for the soak and attack tests (soak.py, attack.py)."""
import atexit
import json
import os
import re
import signal
import subprocess
import time


def waitUntil(cond, timeout, step=0.05):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(step)
    return cond()


class Hub(object):
    """The real hub (SKROBOT_BIN) on /tmp/<name>-<pid> with a data directory in `workdir` and
    the development account; `fail(why)` collects what went wrong when it stops."""

    def __init__(self, workdir, name, fail, server=None):
        self.dir = workdir
        self.fail = fail
        self.app = "%s-%d" % (name, os.getpid())
        self.data = os.path.join(workdir, "data")
        cfg = {
            "app_name": self.app,
            "data_dir": self.data,
            "accounts": {"dev_account": {"user": "guest", "password": "password"}},
            "server": (server if server is not None
                       else {"user_limits": {"connections": 4000, "channels": 4000}}),
        }
        self.config = os.path.join(workdir, "hub.json")
        with open(self.config, "w") as f:
            json.dump(cfg, f)
        self.address = "local:/tmp/" + self.app
        self.proc = None
        self.runs = 0
        atexit.register(self.kill)  # whatever way the test ends, no hub outlives it

    def kill(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def logPath(self):
        return os.path.join(self.dir, "hub-%d.log" % self.runs)

    def log(self):
        with open(self.logPath(), errors="replace") as f:
            return f.read()

    def start(self):
        self.runs += 1
        env = dict(os.environ)
        # A bounded quarantine, so that memory measures the hub and not ASan's holding area.
        env["ASAN_OPTIONS"] = "quarantine_size_mb=16:detect_leaks=1:" + env.get("ASAN_OPTIONS", "")
        out = open(self.logPath(), "w")
        self.proc = subprocess.Popen([os.environ["SKROBOT_BIN"], "--config", self.config],
                                     stdout=out, stderr=subprocess.STDOUT, env=env)
        out.close()
        if not waitUntil(lambda: "HUB-READY" in self.log() or self.proc.poll() is not None, 60):
            raise SystemExit("the hub did not start:\n" + self.log())
        if self.proc.poll() is not None:
            raise SystemExit("the hub exited at start:\n" + self.log())
        self.started = time.monotonic()

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
            self.fail("run %d: the hub did not stop within 60 s of SIGTERM" % self.runs)
        text = self.log()
        if code != 0:
            self.fail("run %d: the hub exited %d" % (self.runs, code))
        for marker in ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:"):
            if marker in text:
                at = text.index(marker)
                self.fail("run %d: %s\n%s" % (self.runs, marker, text[at:at + 3000]))
        return code

    def rssKiB(self):
        with open("/proc/%d/status" % self.proc.pid) as f:
            return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1))

    def fds(self):
        """(descriptors other than the database logs, database logs, what the others are)."""
        other, logs, kinds = 0, 0, []
        fd_dir = "/proc/%d/fd" % self.proc.pid
        for fd in os.listdir(fd_dir):
            try:
                target = os.readlink(os.path.join(fd_dir, fd))
            except OSError:
                continue
            if target.startswith(self.data) and target.endswith(".log"):
                logs += 1
            else:
                other += 1
                kinds.append(re.sub(r"\[\d+\]$", "", target))
        return other, logs, sorted(kinds)
