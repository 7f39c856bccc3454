# SPDX-License-Identifier: Apache-2.0
"""PySketch over TLS (tls: addresses, Python's ssl module), under Python 3 and 2.7: FlowSync and
FlowSat against a hub whose TCP listener speaks TLS, the CA from setTls() or ROBOT_TLS_CA, a
client certificate when the hub asks for one; refusals (plain tcp: to the TLS port, an untrusted
hub, no client certificate) are clear errors, and the hub goes on. Certificates are made at test
time by tests/support/make_test_certs.sh (openssl CLI)."""
from __future__ import print_function

import array
import json
import os
import re
import shutil
import struct
import subprocess
import tempfile
import unittest

from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat
from PySketch.flowsync import FlowSync

from tests.compat import TextIO, redirect_stderr
from tests.hubtest import Hub, pump, skrobotBin, waitUntil

HERE = os.path.dirname(os.path.abspath(__file__))
MAKE_CERTS = os.path.join(HERE, "..", "..", "..", "tests", "support", "make_test_certs.sh")
USER, PASSWORD = "alice", "s3cret-pass"


class TlsHub(Hub):
    """A hub with the account alice and TCP (any free port): TLS with the certificates from
    `certs` unless tls=False."""

    def __init__(self, name, certs, client_ca=False, tls=True):
        Hub.__init__(self, name)
        users = os.path.join(self.dir, "users.json")
        add = subprocess.Popen([skrobotBin(), "user", "add", USER, "--users", users,
                                "--password-stdin"], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        add.communicate((PASSWORD + "\n").encode())
        with open(self.config) as f:
            cfg = json.load(f)
        cfg["server"] = {"tcp": True, "tcp_port": 0}
        if tls:
            cfg["server"]["tls"] = {"cert": os.path.join(certs, "hub.pem"),
                                    "key": os.path.join(certs, "hub.key")}
            if client_ca:
                cfg["server"]["tls"]["client_ca"] = os.path.join(certs, "ca.pem")
        cfg["accounts"]["users_file"] = users
        with open(self.config, "w") as f:
            json.dump(cfg, f)

    def port(self):
        m = re.search(r"FLOW-LISTEN (?:TLS|TCP) 127\.0\.0\.1:(\d+)", self.log())
        return int(m.group(1))

    def refusals(self):
        return len(re.findall(r"FLOW-TLS refusing", self.log()))


class TlsTestCase(unittest.TestCase):
    client_ca = False

    @classmethod
    def setUpClass(cls):
        cls.certs = tempfile.mkdtemp(prefix="pysat-certs-")
        subprocess.check_call(["sh", MAKE_CERTS, cls.certs])
        cls.hub = TlsHub("tls", cls.certs, cls.client_ca).start()

    @classmethod
    def tearDownClass(cls):
        cls.hub.close()
        shutil.rmtree(cls.certs, ignore_errors=True)

    def setUp(self):
        self._closers = []
        os.environ.pop("ROBOT_TLS_CA", None)

    def tearDown(self):
        for c in self._closers:
            c()
        os.environ.pop("ROBOT_TLS_CA", None)

    def cert(self, name):
        return os.path.join(self.certs, name)

    def address(self, scheme="tls", host="localhost"):
        return "%s:%s:%d" % (scheme, host, self.hub.port())

    def sync(self, ca="ca.pem", client=None):
        s = FlowSync(user=USER, password=PASSWORD)
        s.setTls(self.cert(ca) if ca else None,
                 self.cert(client + ".pem") if client else None,
                 self.cert(client + ".key") if client else None)
        self._closers.append(s.close)
        return s

    def flowSat(self, ca="ca.pem", client=None):
        s = FlowSat()
        s.setLogin(USER, PASSWORD)
        s.setTickTimer(0.005)
        s.setTls(self.cert(ca) if ca else None,
                 self.cert(client + ".pem") if client else None,
                 self.cert(client + ".key") if client else None)
        self._closers.append(s.close)
        return s

    def assertRefused(self, connect, expected):
        """connect() fails and the message (logged) mentions `expected`."""
        errs = TextIO()
        with redirect_stderr(errs):
            ok = connect()
        self.assertFalse(ok)
        self.assertIn(expected, errs.getvalue())
        return errs.getvalue()


class OverTls(TlsTestCase):
    def test_sync_connection_reads_and_writes_a_database(self):
        s = self.sync()
        self.assertTrue(s.connect(self.address()), s.lastError)
        self.assertTrue(s.setVariable("colour", "green"))
        self.assertEqual(s.getVariable("colour"), "green")
        # The CA from the environment; a numeric host checked against the certificate's IPs.
        os.environ["ROBOT_TLS_CA"] = self.cert("ca.pem")
        s2 = self.sync(ca=None)
        self.assertTrue(s2.connect(self.address(host="127.0.0.1")), s2.lastError)
        self.assertEqual(s2.getVariable("colour"), "green")

    def test_flows_publish_and_subscribe(self):
        pub, sub = self.flowSat(), self.flowSat()
        self.assertTrue(pub.connect(self.address()))
        self.assertTrue(sub.connect(self.address()))
        data = []
        sub.setGrabDataCallBack(lambda chanID, d: data.append(bytes(d)))
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "n"))
        # Each side learns of the channel on its own: the owner from the hub's answer.
        self.assertTrue(pump([pub, sub], lambda: sub.channelByName("alice.n") is not None
                             and pub.channelByName("alice.n") is not None))
        self.assertTrue(sub.subscribeChannel("alice.n"))
        mine = pub.channelByName("alice.n")
        self.assertTrue(pump([pub, sub], lambda: mine.isPublishingEnabled))
        big = b"x" * 300000   # many TLS records
        floats = array.array("f", range(100000))  # a buffer: copied once, then encrypted
        sent = [("%d" % i).encode() for i in range(50)] + [big, bytearray(b"ba"), floats]
        for payload in sent:
            self.assertTrue(pub.publish(mine.chanID, payload))
        floats[0] = -1.0  # published already: changes nothing
        self.assertTrue(pump([pub, sub], lambda: len(data) >= len(sent)), len(data))
        self.assertEqual(data, sent[:-2] + [b"ba", struct.pack("<100000f", *range(100000))])
        self.assertIn("(alice/", self.hub.log())

    def test_refusals_are_clear_and_the_hub_goes_on(self):
        before = self.hub.refusals()
        plain = FlowSync(user=USER, password=PASSWORD)
        self._closers.append(plain.close)
        self.assertRefused(lambda: plain.connect(self.address("tcp")), "speaks TLS")
        untrusted = self.sync(ca="self-signed.pem")   # not the CA that signed the hub
        self.assertRefused(lambda: untrusted.connect(self.address()), "TLS with tls:")
        flow = self.flowSat(ca="self-signed.pem")
        self.assertRefused(lambda: flow.connect(self.address()), "TLS with tls:")
        self.assertTrue(waitUntil(lambda: self.hub.refusals() >= before + 3), self.hub.log())
        good = self.sync()
        self.assertTrue(good.connect(self.address()), good.lastError)


class PlainPort(TlsTestCase):
    """A tls: address to a hub whose TCP port is plain."""

    @classmethod
    def setUpClass(cls):
        cls.certs = tempfile.mkdtemp(prefix="pysat-certs-")
        subprocess.check_call(["sh", MAKE_CERTS, cls.certs])
        cls.hub = TlsHub("plain", cls.certs, tls=False).start()

    def test_tls_to_a_plain_port_is_refused_clearly(self):
        s = self.sync()
        self.assertRefused(lambda: s.connect(self.address()), "is its TCP port plain?")
        f = self.flowSat()
        self.assertRefused(lambda: f.connect(self.address()), "is its TCP port plain?")
        self.assertTrue(waitUntil(lambda: "a TLS client on the plain TCP port" in self.hub.log()),
                        self.hub.log())
        plain = FlowSync(user=USER, password=PASSWORD)
        self._closers.append(plain.close)
        self.assertTrue(plain.connect(self.address("tcp")), plain.lastError)


class ClientCertificates(TlsTestCase):
    client_ca = True

    def test_a_client_certificate_is_required(self):
        self.assertIn("client certificates required", self.hub.log())
        before = self.hub.refusals()
        none = self.sync()
        out = self.assertRefused(lambda: none.connect(self.address()), "FlowSync: cannot connect")
        self.assertTrue(re.search(r"(?i)certificate.required|handshake|alert", out), out)
        self.assertTrue(waitUntil(lambda: self.hub.refusals() > before), self.hub.log())
        s = self.sync(client="client")
        self.assertTrue(s.connect(self.address()), s.lastError)
        f = self.flowSat(client="client")
        self.assertTrue(f.connect(self.address()))


if __name__ == "__main__":
    unittest.main()
